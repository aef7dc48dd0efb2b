"""Presentation helpers: what a screen shows of a correction, a comparison or a drift.

Pure functions from pipeline results to plain rows and short strings, so that the
TUI (and any other front end) shows numbers without computing them: widgets only
lay these rows out.  Nothing here reads or writes files.

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
import numpy.typing as npt
import pandas as pd

from setupfix.model import PartMeasurement, ProcessModel, normalise_name
from setupfix.model.measurements import suggest_names
from setupfix.objective import margins as objective_margins
from setupfix.pipeline.compare import Comparison
from setupfix.pipeline.diagnose import DiagnoseOutcome, note_text
from setupfix.pipeline.requests import CycleCorrection
from setupfix.pipeline.thermal import DriftPrediction

__all__ = [
    "IN", "OUT", "BINDING", "PREDICTED_OUT", "GIVEN_UP", "GUARD", "REJECTED",
    "DimensionRow", "dimension_rows", "stations", "filter_rows", "sort_rows", "SORT_KEYS",
    "zone_bar", "RegisterRow", "register_rows", "Summary", "summary",
    "MatchRow", "match_rows", "matched_rows", "convergence", "compare_rows", "DriftView", "drift_view",
    "signed", "limits_text", "CycleBudget", "cycle_budgets", "EffectRow", "DiagnosisView", "diagnosis_view",
]

IN, OUT, BINDING, PREDICTED_OUT, GIVEN_UP, GUARD, REJECTED = "✓", "✗", "●", "▲", "⚑", "◇", "⊘"
Array = npt.NDArray[np.float64]


def signed(value: float | None, digits: int = 4) -> str:
    """``+0.0123`` / ``-0.0123``; an em dash for a missing or non-finite value."""
    if value is None or not math.isfinite(value):
        return "—"
    return f"{value + 0.0:+.{digits}f}"


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
        return (zone_bar(self.deviation, self.lower, self.upper, width),
                zone_bar(self.predicted, self.lower, self.upper, width))


def dimension_rows(correction: CycleCorrection) -> list[DimensionRow]:
    """Rows of the dimension table, in model order."""
    rows = []
    for row in correction.dimension_rows():
        before = float(objective_margins(np.array([row["deviation"]]), np.array([row["lower"]]),
                                         np.array([row["upper"]]))[0])
        rows.append(DimensionRow(
            id=row["id"], name=row["name"], station=row.get("station") or "", deviation=row["deviation"],
            lower=row["lower"], upper=row["upper"], predicted=row["predicted"], margin_before=before,
            margin_after=row["margin"], flags_=tuple(row.get("flags", ()))))
    return rows


def stations(rows: Iterable[DimensionRow]) -> list[str]:
    """Stations (model groups) present in ``rows``, in order of appearance."""
    return list(dict.fromkeys(r.station for r in rows if r.station))


def filter_rows(rows: Sequence[DimensionRow], station: str | None) -> list[DimensionRow]:
    """Rows of one station (all rows when ``station`` is None)."""
    return list(rows) if station is None else [r for r in rows if r.station == station]


#: Sort keys of the dimension table: column key → row attribute.
SORT_KEYS: dict[str, str] = {
    "name": "name", "station": "station", "deviation": "deviation", "predicted": "predicted",
    "margin_before": "margin_before", "margin_after": "margin_after",
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
        rows.append(RegisterRow(reg["id"], reg["register"], reg["kind"], str(reg.get("offset", "")),
                                float(exported.get(reg["id"], reg["delta"])) + 0.0, bool(reg["fixed"]),
                                bool(reg["at_limit"]),
                                None if cur is None else float(cur), tuple(dict.fromkeys(rules.get(reg["id"], ()))),
                                component))
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


def summary(correction: CycleCorrection) -> Summary:
    """The verdict and every rule that changed it, δ before and after, the bonus, the notes."""
    r = correction.result
    rec = correction.recommendation
    names = {d.id: d.name for d in correction.model.dimensions}
    return Summary(
        report=correction.part.report, part=correction.part.part, unit=correction.model.unit,
        optimizer=r.optimizer, status=r.status, margin_before=correction.margin_before,
        margin_after=correction.margin_after, bonus=correction.margin_after - correction.margin_before,
        norm=correction.norm, bound=r.bound, in_tolerance=correction.margin_after >= 0 and not correction.given_up,
        message=r.message,
        notes=tuple(str(n) for n in correction.notes), verdict=correction.verdict,
        rules=tuple(f"{e.rule}: {e.message}" for e in rec.rules),
        alarm=rec.alarm or ("" if rec.solved else
                            "NOT SOLVED: " + next(e.message for e in rec.rules if e.rule == "not_solved")),
        given_up=tuple(names.get(d, d) for d in correction.given_up), solved=rec.solved)


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
        rows.append(MatchRow(name, _text(rec.get("part")), _text(rec.get("station")), dim,
                             () if dim else suggest_names(model, name, limit)))
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


def convergence(comparison: Comparison, width: int = 60) -> dict[str, Array]:
    """Median best-so-far f1 of each method at ``width`` evenly spaced solution counts.

    The counts run from the first one every trial has recorded to the largest final
    count, so every point is a median over all trials (a finished trial keeps its
    final best).

    Returns
    -------
    dict name → ndarray of shape (width,) [model unit]
    """
    out: dict[str, Array] = {}
    for m in comparison.methods:
        hist = [h for h in m.histories if len(h)]
        if not hist:
            continue
        start = max(float(h[0, 0]) for h in hist)
        end = max(float(h[-1, 0]) for h in hist)
        grid = np.linspace(start, max(end, start), width)
        curves = [h[np.searchsorted(h[:, 0], grid, side="right") - 1, 1] for h in hist]
        out[m.optimizer] = np.median(np.vstack(curves), axis=0)
    return out


def limits_text(lower: float, upper: float, digits: int = 3) -> str:
    """``±0.100`` for a symmetric tolerance, else ``-0.050/+0.100``."""
    if math.isfinite(lower) and math.isfinite(upper) and abs(lower + upper) < 1e-12:
        return f"±{upper:.{digits}f}"
    return f"{signed(lower, digits)}/{signed(upper, digits)}"


def compare_rows(comparison: Comparison) -> list[dict[str, Any]]:
    """The comparison table (exact first) with the skipped methods and their reasons."""
    rows = comparison.table()
    for name, reason in comparison.skipped.items():
        rows.append({"optimizer": name, "skipped": reason})
    return rows


@dataclass(frozen=True)
class DriftView:
    """A drift prediction as the thermal panel shows it."""

    method: str
    target: str
    unit: str  #: the thermal model's unit ("" when it does not say)
    latest: float
    latest_time: str
    recent: Array  #: the last samples of the predicted drift, oldest first
    measured_latest: float | None
    samples: int
    notes: tuple[str, ...] = ()

    @property
    def recent_range(self) -> tuple[float, float]:
        """Lowest and highest drift of the recent curve (the sparkline's scale)."""
        return float(np.min(self.recent)), float(np.max(self.recent))


def drift_view(prediction: DriftPrediction, recent: int = 120) -> DriftView:
    """The latest drift and its recent curve (the last ``recent`` samples)."""
    measured = prediction.measured
    m_last = None
    if measured is not None and len(measured) and np.isfinite(measured[-1]):
        m_last = float(measured[-1])
    return DriftView(prediction.method, prediction.target, (prediction.unit or "").replace("um", "µm"),
                     prediction.latest,
                     prediction.timestamps[-1] if prediction.timestamps else "",
                     np.asarray(prediction.drift[-recent:], dtype=float), m_last, len(prediction.drift),
                     tuple(str(n) for n in prediction.notes))


@dataclass(frozen=True)
class CycleBudget:
    """The error budget δ of one measured cycle, as measured (before its correction)."""

    cycle: str
    timestamp: str
    budget: float
    out_of_tolerance: int
    measured: int


def cycle_budgets(model: ProcessModel, parts: Iterable[PartMeasurement]) -> list[CycleBudget]:
    """δ (eq. 8 on the measured deviations) and the out-of-tolerance count of each cycle."""
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    rows = []
    for p in parts:
        m = p.measured
        margins = objective_margins(p.deviation[m], lower[m], upper[m])
        rows.append(CycleBudget(f"{p.report}:{p.part}" if p.part else p.report, p.timestamp or "",
                                float(margins.min()) if margins.size else math.nan, int((margins < 0).sum()),
                                int(m.sum())))
    return rows


@dataclass(frozen=True)
class EffectRow:
    """One effect the diagnosis found."""

    kind: str
    target: str
    estimate: float
    stderr: float
    unit: str
    rms_after: float
    alike: tuple[str, ...]


@dataclass(frozen=True)
class DiagnosisView:
    """A diagnosis as the history panel shows it: residual before/after, effects, walk forward."""

    cycles: int
    unit: str
    before: tuple[float, float, int]  #: residual RMS, max |residual|, out of tolerance — declared model
    after: tuple[float, float, int]  #: the same with the effects found
    effects: tuple[EffectRow, ...]
    walk: tuple[tuple[str, float, float, float, int], ...]  #: name, mean δ, worst δ, RMS, out of tolerance
    next_correction: tuple[tuple[str, float], ...]  #: registers that move, model ID and change
    notes: tuple[str, ...]
    budgets: tuple[CycleBudget, ...]
    walk_centre: tuple[tuple[str, float, float], ...] = ()  #: name, RMS and mean |·| from the tolerance centre
    next_from: str = "augmented"  #: the model the next correction comes from (augmented, ewma, declared)
    held: tuple[str, ...] = ()  #: registers the centre rule holds (model IDs)


def diagnosis_view(outcome: DiagnoseOutcome) -> DiagnosisView:
    """What the history panel shows of ``setupfix diagnose``'s outcome."""
    d = outcome.diagnosis
    eb, ea = d.error_before, d.error_after
    walk = () if d.walk is None else tuple(
        (name, b.mean_budget, b.worst_budget, b.rms, b.out_of_tolerance) for name, b in d.walk.budgets.items())
    return DiagnosisView(
        cycles=d.series.n_cycles, unit=d.layout.unit,
        before=(eb.rms, eb.max, eb.out_of_tolerance), after=(ea.rms, ea.max, ea.out_of_tolerance),
        effects=tuple(EffectRow(e.kind, e.target, e.estimate, e.stderr, e.unit, e.rms_after, tuple(e.alike))
                      for e in d.effects),
        walk=walk, next_correction=tuple((k, v) for k, v in outcome.next_correction.items() if v != 0),
        notes=tuple(note_text(n) for n in outcome.notes),
        budgets=tuple(cycle_budgets(outcome.input.model, outcome.input.parts)),
        walk_centre=() if d.walk is None else tuple(
            (name, b.centre_rms, b.centre_mean_abs) for name, b in d.walk.budgets.items()),
        next_from=d.next_from.source,
        held=() if d.centred is None else tuple(r for r, h in zip(d.layout.register_ids, d.centred, strict=True)
                                                if h))
