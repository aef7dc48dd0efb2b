"""Presentation helpers of a correction: what a screen shows of its dimensions, registers, verdict and match.

Pure functions from pipeline results to plain rows and short strings, so that the
TUI (and any other front end) shows numbers without computing them: widgets only
lay these rows out.  Nothing here reads or writes files.  A comparison, a drift and a
diagnosis are shown through :mod:`setupfix.views.analysis`.

Symbols carry every state as well as colour does, for monochrome terminals:

======  ==================================================================
``✓``   in tolerance
``✗``   out of tolerance
``●``   binding: one of the dimensions that stop a better correction
``▲``   predicted out of tolerance after the correction
``◇``   predicted inside the limits but within the measurement uncertainty U of one
``⚑``   given up: no setup correction can bring it in (NC program / process)
``⊘``   beyond the reject band: the reason the verdict is *reject*
======  ==================================================================
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from setupfix.correction.numbers import fmt
from setupfix.correction.objective import margins as objective_margins
from setupfix.correction.recommend import stopped_where
from setupfix.model import PartMeasurement, ProcessModel, normalise_name
from setupfix.model.measurements import suggest_names
from setupfix.usecases.contract import one_line
from setupfix.usecases.requests import CycleCorrection

__all__ = [
    "IN",
    "OUT",
    "BINDING",
    "PREDICTED_OUT",
    "GIVEN_UP",
    "GUARD",
    "REJECTED",
    "DimensionRow",
    "dimension_rows",
    "stations",
    "filter_rows",
    "sort_rows",
    "SORT_KEYS",
    "zone_bar",
    "RegisterRow",
    "register_rows",
    "Summary",
    "summary",
    "MatchRow",
    "match_rows",
    "matched_rows",
    "signed",
    "limits_text",
    "conformance_lines",
    "CONFORMANCE_TEXT",
    "SOURCE_TEXT",
]

IN, OUT, BINDING, PREDICTED_OUT, GIVEN_UP, GUARD, REJECTED = "✓", "✗", "●", "▲", "⚑", "◇", "⊘"


def signed(value: float | None, digits: int = 4) -> str:
    """``+0.0123`` / ``-0.0123`` (never ``-0.0000``: :func:`~setupfix.correction.numbers.fmt`); an em dash
    for a missing or non-finite value."""
    return fmt(value, digits, sign=True)


def zone_bar(value: float, lower: float, upper: float, width: int = 11) -> str:
    """The tolerance zone as ``width`` characters with the value marked.

    ``├`` and ``┤`` are the limits, ``┼`` the nominal, ``●`` the value inside the
    zone; a value beyond a limit shows ``◀`` or ``▶`` at that end.  A one-sided
    tolerance is drawn symmetric about nominal with the finite limit.
    """
    width = max(width, 5)
    lo, hi = lower, upper
    if not math.isfinite(lo) and not math.isfinite(hi):
        lo, hi = -1.0, 1.0
    elif not math.isfinite(lo):
        lo = -abs(hi) if hi > 0 else hi - 1.0
    elif not math.isfinite(hi):
        hi = abs(lo) if lo < 0 else lo + 1.0
    cells = ["─"] * width
    cells[0], cells[-1] = "├", "┤"
    if lo < 0 < hi:
        cells[_cell((0 - lo) / (hi - lo), width)] = "┼"
    if not math.isfinite(value):
        return "".join(cells)
    if value < lower:
        cells[0] = "◀"
    elif value > upper:
        cells[-1] = "▶"
    else:
        cells[_cell(min(max((value - lo) / (hi - lo), 0.0), 1.0), width)] = "●"
    return "".join(cells)


def _cell(fraction: float, width: int) -> int:
    """Cell of a fraction of the zone; halves round away from the centre (symmetric bars)."""
    pos = fraction * (width - 1)
    centre = (width - 1) / 2
    return math.floor(pos + 0.5 + 1e-9) if pos >= centre else math.ceil(pos - 0.5 - 1e-9)


@dataclass(frozen=True)
class DimensionRow:
    """One measured dimension before and after the correction [model unit].

    ``flags`` are the pipeline's (:meth:`CycleCorrection.dimension_rows`): ``out_before``,
    ``out`` (predicted out after the changes), ``guard``, ``binding``, ``given_up``,
    ``rejected``.
    """

    id: str
    name: str
    station: str
    deviation: float
    lower: float
    upper: float
    predicted: float
    margin_before: float
    margin_after: float
    flags_: tuple[str, ...] = ()
    zone: tuple[float, float, float] | None = None  # a position zone: CMM diameters measured, predicted; ⌀

    @property
    def position_text(self) -> str:
        """A position zone as a CMM prints it, ``⌀0.086 → ⌀0.000 of ⌀0.100`` (2 × the radial distance); else ""."""
        if self.zone is None:
            return ""
        measured, predicted, diameter = self.zone
        return f"⌀{measured:.3f} → ⌀{predicted:.3f} of ⌀{diameter:.3f}"

    @property
    def binding(self) -> bool:
        return "binding" in self.flags_

    @property
    def in_before(self) -> bool:
        return "out_before" not in self.flags_

    @property
    def in_after(self) -> bool:
        return "out" not in self.flags_

    @property
    def flags(self) -> str:
        """The state symbols of the row (see the module docstring)."""
        f = self.flags_
        text = (IN if self.in_before else OUT) + (PREDICTED_OUT if "out" in f else GUARD if "guard" in f else IN)
        for name, symbol in (("binding", BINDING), ("given_up", GIVEN_UP), ("rejected", REJECTED)):
            if name in f:
                text += symbol
        return text

    def bars(self, width: int = 11) -> tuple[str, str]:
        """Tolerance-zone bars before and after the correction."""
        return (
            zone_bar(self.deviation, self.lower, self.upper, width),
            zone_bar(self.predicted, self.lower, self.upper, width),
        )


def dimension_rows(correction: CycleCorrection) -> list[DimensionRow]:
    """Rows of the dimension table, in model order."""
    rows = []
    for row in correction.dimension_rows():
        before = float(
            objective_margins(np.array([row["deviation"]]), np.array([row["lower"]]), np.array([row["upper"]]))[0]
        )
        rows.append(
            DimensionRow(
                id=row["id"],
                name=row["name"],
                station=row.get("station") or "",
                deviation=row["deviation"],
                lower=row["lower"],
                upper=row["upper"],
                predicted=row["predicted"],
                margin_before=before,
                margin_after=row["margin"],
                flags_=tuple(row.get("flags", ())),
                zone=(row["zone_position"], row["zone_position_predicted"], row["zone_diameter"])
                if "zone_position" in row
                else None,
            )
        )
    return rows


def stations(rows: Iterable[DimensionRow]) -> list[str]:
    """Stations (model groups) present in ``rows``, in order of appearance."""
    return list(dict.fromkeys(r.station for r in rows if r.station))


def filter_rows(rows: Sequence[DimensionRow], station: str | None) -> list[DimensionRow]:
    """Rows of one station (all rows when ``station`` is None)."""
    return list(rows) if station is None else [r for r in rows if r.station == station]


#: Sort keys of the dimension table: column key → row attribute.
SORT_KEYS: dict[str, str] = {
    "name": "name",
    "station": "station",
    "deviation": "deviation",
    "predicted": "predicted",
    "margin_before": "margin_before",
    "margin_after": "margin_after",
}


def sort_rows(rows: Sequence[DimensionRow], key: str, *, reverse: bool = False) -> list[DimensionRow]:
    """Rows sorted by one column of :data:`SORT_KEYS` (stable, model order breaks ties)."""
    return sorted(rows, key=lambda r: getattr(r, SORT_KEYS[key]), reverse=reverse)


@dataclass(frozen=True)
class RegisterRow:
    """One register (component) of the recommendation [model unit; a rotation ``W1.C`` in degrees].

    ``component`` is the register component of a multi-axis model (X, Y, Z, C, R; a tool length
    the spindle axis), ``None`` in a one-axis model.
    """

    id: str
    register: str
    kind: str
    offset: str
    delta: float
    fixed: bool
    at_limit: bool
    current: float | None = None
    rules: tuple[str, ...] = ()
    component: str | None = None

    @property
    def new(self) -> float | None:
        """The value to set when the current value is known."""
        return None if self.current is None else self.current + self.delta

    @property
    def flags(self) -> str:
        return "fixed" if self.fixed else ("◆limit" if self.at_limit else "")


def register_rows(correction: CycleCorrection, current: Mapping[str, float] | None = None) -> list[RegisterRow]:
    """Every register of the model (fixed ones too, with 0), in model order, with the
    safety rules that changed it.

    ``delta`` is the change the export writes (the thermal feed-forward included, rule
    ``thermal``); ``current`` maps model ID or controller name to the value in the controller.
    """
    current = current or {}
    rules: dict[str, list[str]] = {}
    for effect in correction.rules:
        for rid in effect.registers:
            rules.setdefault(rid, []).append(effect.rule)
    exported = correction.corrections
    fed = correction.thermal.corrections() if correction.thermal is not None and correction.verdict != "reject" else {}
    for rid in fed:
        rules.setdefault(rid, []).append("thermal")
    rows = []
    for reg in correction.register_rows():
        component = reg.get("component")
        # a component's current value is its own: the register's name (G54) is shared by its components
        cur = current.get(reg["id"], current.get(reg["register"]) if component is None else None)
        rows.append(
            RegisterRow(
                reg["id"],
                reg["register"],
                reg["kind"],
                str(reg.get("offset", "")),
                float(exported.get(reg["id"], reg["delta"])) + 0.0,
                bool(reg["fixed"]),
                bool(reg["at_limit"]),
                None if cur is None else float(cur),
                tuple(dict.fromkeys(rules.get(reg["id"], ()))),
                component,
            )
        )
    return rows


@dataclass(frozen=True)
class Summary:
    """The headline of a correction: verdict, δ before and after, bonus, rules, notes."""

    report: str
    part: str
    unit: str
    optimizer: str
    status: str
    margin_before: float
    margin_after: float
    bonus: float
    norm: float
    bound: float | None
    in_tolerance: bool
    message: str
    notes: tuple[str, ...]
    verdict: str
    rules: tuple[str, ...] = ()
    alarm: str = ""
    given_up: tuple[str, ...] = ()
    solved: bool = True  #: False: the solve was stopped with nothing proven (``alarm`` says so)
    #: where and why a stopped solve stopped (``"work limit in the leximin stage"``; empty: proved)
    stopped: str = ""


def summary(correction: CycleCorrection) -> Summary:
    """The verdict and every rule that changed it, δ before and after, the bonus, the notes."""
    r = correction.result
    rec = correction.recommendation
    names = {d.id: d.name for d in correction.model.dimensions}
    return Summary(
        report=correction.part.report,
        part=correction.part.part,
        unit=correction.model.unit,
        optimizer=r.optimizer,
        status=r.status,
        margin_before=correction.margin_before,
        margin_after=correction.margin_after,
        bonus=correction.margin_after - correction.margin_before,
        norm=correction.norm,
        bound=r.bound,
        in_tolerance=correction.margin_after >= 0 and not correction.given_up,
        message=r.message,
        notes=tuple(str(n) for n in correction.notes),
        verdict=correction.verdict,
        rules=tuple(f"{e.rule}: {e.message}" for e in rec.rules),
        alarm=rec.alarm
        or ("" if rec.solved else "NOT SOLVED: " + next(e.message for e in rec.rules if e.rule == "not_solved")),
        given_up=tuple(names.get(d, d) for d in correction.given_up),
        solved=rec.solved,
        stopped=stopped_where(r),
    )


@dataclass(frozen=True)
class MatchRow:
    """A report characteristic and the model dimension it matches, or close names."""

    characteristic: str
    part: str
    station: str
    dimension: str
    suggestions: tuple[str, ...]

    @property
    def matched(self) -> bool:
        return bool(self.dimension)


def match_rows(model: ProcessModel, table: pd.DataFrame, *, limit: int = 3) -> list[MatchRow]:
    """Each characteristic of a report with the dimension it matches (by name or alias,
    case and blanks ignored) or, failing that, the closest dimension names
    (:func:`setupfix.model.measurements.suggest_names`)."""
    keys: dict[str, str] = {}
    for d in model.dimensions:
        for k in d.keys:
            keys.setdefault(k, d.id)
    rows = []
    for rec in table.to_dict("records"):
        name = str(rec.get("characteristic", ""))
        dim = keys.get(normalise_name(name), "")
        rows.append(
            MatchRow(
                name,
                _text(rec.get("part")),
                _text(rec.get("station")),
                dim,
                () if dim else suggest_names(model, name, limit),
            )
        )
    return rows


def matched_rows(model: ProcessModel, parts: Iterable[PartMeasurement]) -> list[MatchRow]:
    """The match table of parts already tied to the model: every measured dimension,
    then every unmatched characteristic with its suggestions."""
    rows = []
    for p in parts:
        for dim, value in zip(model.dimensions, p.deviation, strict=True):
            if math.isfinite(value):
                rows.append(MatchRow(dim.name, p.part, dim.group or "", dim.id, ()))
        for name in p.unmatched:
            rows.append(MatchRow(name, p.part, "", "", tuple(p.suggestions.get(name, ()))))
    return rows


def _text(value: Any) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value)


def limits_text(lower: float, upper: float, digits: int = 3) -> str:
    """``±0.100`` for a symmetric tolerance, else ``-0.050/+0.100``."""
    if math.isfinite(lower) and math.isfinite(upper) and abs(lower + upper) < 1e-12:
        return f"±{upper:.{digits}f}"
    return f"{signed(lower, digits)}/{signed(upper, digits)}"


#: How a verdict of ISO 14253-1 reads in the text (``conformance_before`` / ``_after``).
CONFORMANCE_TEXT = {"conforming": "conforming", "not_proven": "not proven", "nonconforming": "NONCONFORMING"}
#: Where a U comes from, as the text says it.
SOURCE_TEXT = {"report": "report", "dimension": "model, dimension", "measurement": "model", "mpe": "CMM MPE"}


def conformance_lines(rows: Sequence[Mapping[str, Any]], unit: str) -> list[str]:
    """The measurement uncertainty of each dimension, where it comes from and its ISO 14253-1 verdicts.

    ``rows``: :meth:`CycleCorrection.dimension_rows`.  Empty when no dimension has a U (conforming
    then means in tolerance, which the table's flags already say).
    """
    with_u = [r for r in rows if r.get("uncertainty", 0.0)]
    if not with_u:
        return []
    w = max(len(one_line(r["name"])) for r in with_u) + 2
    lines = ["", f"measurement uncertainty U (k = 2) [{unit}] and ISO 14253-1 verdicts, before → after:"]
    for r in with_u:
        before = CONFORMANCE_TEXT.get(r["conformance_before"], r["conformance_before"])
        after = CONFORMANCE_TEXT.get(r["conformance_after"], r["conformance_after"])
        source = SOURCE_TEXT.get(r["uncertainty_source"], r["uncertainty_source"])
        lines.append(f"  {one_line(r['name']):<{w}}U {fmt(r['uncertainty'], 4)} ({source})  {before} → {after}")
    return lines
