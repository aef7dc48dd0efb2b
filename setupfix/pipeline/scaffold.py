"""Use case "model init": a process-model scaffold from CMM reports.

Every toleranced length characteristic of the reports becomes a dimension (its name,
nominal and limits as the report states them, ``group`` = the report's station, or its
part with ``parts_are_stations``), each
entered by a feature of its own, and every feature moved by one WKS (``W1``, G54) and
one tool (``T1``, H1): a starting topology that loads at once and with which
``setupfix correct`` runs on the same reports.  The comments in the file say what to
edit (which registers move which feature, with which sign).

The axis of a characteristic is, first, the one the report states — the ``axis`` column
of the canonical table (:mod:`parsers.axes`: a DMIS ``CORTOL`` axis word, a QIF
``LinearCoordinate`` direction or ``AnalysisVector``, a plane or point normal within 5°
of an axis) — and, where the report states none, the one its name states (a token
``X``, ``Y`` or ``Z``: ``SP_00_Z``, ``Cono_9_X``, ``Step 5.Z Location``, ``Distanz X
4mm``).  When both state one and they differ, the report's vector wins and the
dimension's comment names both.  Each dimension's comment says where its axis came
from.  ``axis=`` keeps one axis (and the characteristics whose axis neither tells);
the process axis is that axis, else the one most dimensions state (``Z`` on a tie or
when none does).

Left out, each listed in the file's head with its reason: reference-only rows, rows
with no limit or only one (the contract needs both; none is invented), form and
orientation tolerances (flatness, perpendicularity, … by name: no offset moves them),
values outside the model's sanity ranges, and other axes with ``axis=``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

import parsers
from parsers.axes import AXES, AXIS_COLUMN
from setupfix.errors import ModelError, Note, ParseError, SetupfixError, SourceLocation
from setupfix.model import normalise_name
from setupfix.model.loader import RANGES_MM
from setupfix.pipeline.cycles import ReadOptions

__all__ = ["Scaffold", "scaffold_model", "scaffold_from_tables", "name_axis", "FORM_WORDS"]

#: Words naming a form or orientation tolerance (English, German, Korean): no setup offset moves them.
FORM_WORDS = (
    "flatness", "straightness", "roundness", "circularity", "cylindricity", "sphericity", "parallelism",
    "perpendicularity", "angularity", "runout", "concentricity", "symmetry", "ebenheit", "geradheit",
    "rundheit", "zylindrizität", "parallelität", "rechtwinkligkeit", "neigung", "lauf", "평면도", "진원도",
    "진직도", "원통도", "평행도", "직각도", "경사도", "흔들림", "동심도",
)
_TOKENS = re.compile(r"[\s_.\-/:;,()\[\]#]+")


def name_axis(name: str) -> str | None:
    """The axis a characteristic's name states: the one token ``X``, ``Y`` or ``Z`` (any case), else None."""
    axes = {t.upper() for t in _TOKENS.split(name) if t.upper() in ("X", "Y", "Z")}
    return axes.pop() if len(axes) == 1 else None


def _is_form(name: str) -> bool:
    folded = name.casefold()
    return any(word in folded for word in FORM_WORDS)


def _toml_string(text: str) -> str:
    """A TOML basic string (JSON escapes are TOML escapes; DEL is escaped too)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _comment(text: str) -> str:
    """Text safe inside a TOML comment (one line, no control characters)."""
    return "".join(c if c.isprintable() else "?" for c in text)


def _number(value: float) -> str:
    text = f"{value:.12g}"
    return text if any(c in text for c in ".en") else text + ".0"


@dataclass
class _Dim:
    name: str
    group: str | None
    nominal: float
    lower: float
    upper: float
    axis: str | None
    source: str
    #: Where ``axis`` came from: "report" (the axis column), "name", "" (neither states one), or
    #: why there is none although reports state one ("the reports state X and Y").
    axis_from: str = ""
    #: The axis the name states when it differs from the report's.
    name_says: str | None = None

    def axis_note(self) -> str:
        """The comment on the dimension's axis: which one, and from what."""
        if self.axis is None:
            return f"no axis: {self.axis_from}" if self.axis_from else "no axis stated"
        if self.axis_from == "report":
            return f"axis {self.axis} stated by the report" + (
                f" (its name says {self.name_says}: the report's vector wins)" if self.name_says else "")
        return f"axis {self.axis} from the name"


def _stated_axis(value: Any, where: str, report: str) -> str | None:
    """A cell of the ``axis`` column: X, Y or Z (any case), None when empty; anything else is refused."""
    if value is None or value != value:
        return None
    text = str(value).strip().upper()
    if text in AXES:
        return text
    if text in ("", "NAN"):
        return None
    head, sep, tail = where.rpartition(":")
    location = SourceLocation(head, line=int(tail)) if sep and tail.isdigit() else SourceLocation(where or report)
    raise ParseError(f"column 'axis': expected X, Y, Z or empty, found {str(value)!r}", location=location)


@dataclass(frozen=True)
class Scaffold:
    """The scaffold text and what went into it."""

    text: str
    dimensions: int
    axis: str
    skipped: tuple[tuple[str, str], ...] = ()  # (characteristic, reason)
    #: What the folder listing could not look at, files left out and the readers' notes (skipped rows, units).
    notes: tuple[Note, ...] = ()
    #: How many dimensions took their axis from the report, from the name, or have none.
    axes_from: Mapping[str, int] = field(default_factory=dict)


def _resolution(narrowest: float | None) -> float:
    """0.001 mm, finer by powers of ten until it is at most half the narrowest tolerance band."""
    res = 0.001
    while narrowest is not None and res > narrowest / 2 and res > RANGES_MM["resolution"][0]:
        res /= 10
    return res


def _collect(tables: Sequence[tuple[str, pd.DataFrame]], axis: str | None,
             group_column: str = "station") -> tuple[list[_Dim], list[tuple[str, str]]]:
    dims: dict[tuple[str, str | None], _Dim] = {}
    skipped: dict[str, str] = {}
    nom_lo, nom_hi = RANGES_MM["nominal"]
    tol_lo, tol_hi = RANGES_MM["tolerance"]
    for report, table in tables:
        count = len(table)

        def col(name: str, rows: int = count, frame: pd.DataFrame = table) -> list[Any]:
            return frame[name].tolist() if name in frame else [None] * rows

        for name, nominal, lower, upper, station, reference, where, stated in zip(
                col("characteristic"), col("nominal"), col("lower"), col("upper"), col(group_column),
                col("reference"), col("source"), col(AXIS_COLUMN), strict=True):
            name = str(name).strip()
            if not name or name in skipped:
                continue
            where = str(where) if where is not None and where == where else report
            from_report, from_name = _stated_axis(stated, where, report), name_axis(name)
            dim_axis = from_report or from_name
            nominal, lower, upper = (float(v) if v is not None and v == v else math.nan
                                     for v in (nominal, lower, upper))
            reason = None
            if str(reference).strip().lower() in ("true", "1", "yes"):
                reason = "reference only"
            elif math.isnan(lower) or math.isnan(upper):
                reason = "no tolerance" if math.isnan(lower) and math.isnan(upper) else "one-sided tolerance"
            elif _is_form(name):
                reason = "form or orientation tolerance (no offset moves it)"
            elif not lower < upper:
                reason = f"lower limit {lower:g} not below upper {upper:g}"
            elif upper - lower < 2 * RANGES_MM["resolution"][0]:
                reason = f"tolerance band {upper - lower:g} mm narrower than two steps of the finest resolution"
            elif not (math.isfinite(nominal) and nom_lo <= nominal <= nom_hi):
                reason = f"nominal {nominal:g} outside [{nom_lo:g}, {nom_hi:g}] mm"
            elif not (tol_lo <= lower and upper <= tol_hi):
                reason = f"limits beyond ±{tol_hi:g} mm"
            elif axis is not None and dim_axis not in (None, axis):
                reason = f"axis {dim_axis}{' stated by the report' if from_report else ''} (--axis {axis})"
            if reason:
                skipped[name] = reason
                continue
            group = None if station is None or station != station or str(station).strip() == "" else str(station)
            key = (normalise_name(name), normalise_name(group) if group else None)
            if key not in dims:
                dims[key] = _Dim(name, group, nominal, lower, upper, dim_axis, where,
                                 "report" if from_report else "name" if from_name else "",
                                 from_name if from_report and from_name not in (None, from_report) else None)
                continue
            known = dims[key]
            if from_report and known.axis_from == "report" and known.axis != from_report:
                # two reports state different axes for one dimension: neither is taken
                known.axis_from, known.axis = f"the reports state {known.axis} and {from_report}", None
            elif from_report and known.axis_from in ("", "name") and axis in (None, from_report):
                known.name_says = from_name if from_name not in (None, from_report) else None
                known.axis, known.axis_from = from_report, "report"
    return list(dims.values()), list(skipped.items())


def scaffold_model(reports: Sequence[str | Path], *, axis: str | None = None, name: str | None = None,
                   parts_are_stations: bool = False, read: ReadOptions | None = None) -> Scaffold:
    """Write a process-model scaffold (TOML text) from the reports' toleranced length characteristics.

    ``reports`` may name folders: their reports and those of their sub-folders, as
    :func:`parsers.expand_inputs` lists them (the policy every command shares; what the
    listing could not look at is a note); a file of a folder that no reader takes, or
    that is refused, is left out with a note.  ``read``: the reader's options (default:
    every one sniffed, not lenient).

    Raises
    ------
    ParseError
        If a report named as a file cannot be read, or no file of a folder can.
    ModelError
        If no characteristic qualifies (the message lists why, per kind).
    """
    if axis is not None and axis not in ("X", "Y", "Z"):
        raise ModelError(f'axis must be "X", "Y" or "Z", got {axis!r}')
    options = (read if read is not None else ReadOptions()).kwargs()
    inputs = parsers.expand_inputs(reports)
    if inputs.empty:
        raise ParseError("folder holds no report file", location=SourceLocation(inputs.empty[0]),
                         hint="; ".join(inputs.warnings()[:3]) or None)
    reads: list[tuple[str, parsers.ReadResult]] = []
    left_out: list[Note] = inputs.notes()
    for report, from_folder in inputs.files:
        try:
            result = parsers.read_report(report, **options)
            reads.append((result.source, result))  # its printable name: it goes into the model's comments
        except SetupfixError as exc:
            if not from_folder:
                raise
            hint = f" ({exc.hint})" if exc.hint else ""
            left_out.append(Note(f"{exc.message}{hint}; left out", exc.location, "skipped"))
    if not reads:
        raise ParseError(f"no file of {', '.join(map(str, reports))} is a readable report",
                         location=SourceLocation(str(reports[0])), hint=str(left_out[0]) if left_out else None)
    scaffold = scaffold_from_tables([(r, read.table) for r, read in reads], axis=axis,
                                    name=name, parts_are_stations=parts_are_stations)
    return dataclasses.replace(scaffold, notes=(*left_out, *(n for _, read in reads for n in read.notes)))


def scaffold_from_tables(tables: Sequence[tuple[str, pd.DataFrame]], *, axis: str | None = None,
                         name: str | None = None, parts_are_stations: bool = False) -> Scaffold:
    """:func:`scaffold_model` on canonical tables already read, as (report name, table) pairs.

    ``parts_are_stations``: the report's parts are the fixture's stations (one workpiece
    per part, names repeating): ``group`` = the part, instead of the report's station.
    """
    if axis is not None and axis not in ("X", "Y", "Z"):
        raise ModelError(f'axis must be "X", "Y" or "Z", got {axis!r}')
    reports = [r for r, _ in tables]
    dims, skipped = _collect(tables, axis, "part" if parts_are_stations else "station")
    if not dims:
        reasons = Counter(reason for _, reason in skipped)
        why = "; ".join(f"{n} × {r}" for r, n in reasons.most_common(4)) or "the reports hold no characteristic"
        raise ModelError(f"no toleranced length characteristic to make a dimension of ({why})",
                         location=SourceLocation(", ".join(reports)))
    stated = Counter(d.axis for d in dims if d.axis)
    model_axis = axis or max(("Z", "X", "Y"), key=lambda a: stated[a])  # most stated; Z on a tie or none
    bands = [d.upper - d.lower for d in dims]
    resolution = _resolution(min(bands))
    text = _render(dims, skipped, reports, model_axis, resolution, name, axis)
    origins = Counter(d.axis_from if d.axis_from in ("report", "name") else "none" for d in dims)
    return Scaffold(text, len(dims), model_axis, tuple(skipped),
                    axes_from={k: origins[k] for k in ("report", "name", "none") if origins[k]})


def _render(dims: list[_Dim], skipped: list[tuple[str, str]], reports: Sequence[str | Path], axis: str,
            resolution: float, name: str | None, only_axis: str | None) -> str:
    sources = ", ".join(Path(r).name for r in reports)
    title = name or f"Scaffold from {sources}"
    out = [
        f"# Process model scaffold written by `setupfix model init` from: {_comment(sources)}",
        "# It loads as written and `setupfix correct` runs with it, but its relations are a guess:",
        "#   every feature below is moved by W1 (G54) and T1 (H1) with weight +1 (a feature along",
        "#   another axis than the process's by none). Edit",
        "#   1. [wks.*] and [tools.*]: the registers your NC program really uses (one table each);",
        "#   2. [features.*]: which WKS and tools move each feature, +1 or -1 (a feature cut by",
        "#      the tool's tip facing -axis gets -1), and remove features no offset moves;",
        "#   3. [dimensions.*] features: a distance between two features is { Fa = 1, Fb = -1 };",
        "#   4. group = \"P1\" … where a fixture holds the part at several stations.",
        "# Then `setupfix model show` prints the matrices and `setupfix model check` the match table.",
        f"# {len(dims)} dimension(s); axis {axis}"
        + (f" (kept: dimensions along {only_axis} or with no axis stated)" if only_axis else
           " (the one most dimensions state; other axes are kept: delete them or use --axis)"),
        "# Each dimension's axis is the one the report states (CORTOL axis, QIF direction or vector,",
        "#   a plane or point normal), else the one its name states; its comment says which.",
    ]
    if skipped:
        out.append(f"# Left out ({len(skipped)}):")
        for char, reason in skipped[:200]:
            out.append(f"#   {_comment(char)}: {reason}")
        if len(skipped) > 200:
            out.append(f"#   … and {len(skipped) - 200} more")
    out += [
        "",
        "[process]",
        f"name = {_toml_string(title)}",
        f'axis = "{axis}"',
        'unit = "mm"             # every length below is in mm (the reports were converted)',
        f"{'resolution = ' + _number(resolution):<24}# the controller's offset step",
        "limit = 0.1             # bound on |correction| of every register; per register: limit = …",
        "",
        "[wks.W1]",
        'register = "G54"        # rename; add [wks.W2] register = "G55" … per work offset',
        "",
        "[tools.T1]",
        'register = "H1"         # rename; add [tools.T2] … per tool length offset',
        "",
    ]
    for i, d in enumerate(dims, start=1):
        if d.axis in (None, axis):
            out += [f"[features.F{i}]", "wks = { W1 = 1 }", "tools = { T1 = 1 }", ""]
        else:  # a length along another axis: a shift along this one does not change it
            out += [f"[features.F{i}]  # axis {d.axis}: no {axis} offset moves it (nothing to correct here)",
                    "wks = {}", "tools = {}", ""]
    for i, d in enumerate(dims, start=1):
        out += [f"[dimensions.D{i}]  # {_comment(d.source)}; {_comment(d.axis_note())}",
                f"name = {_toml_string(d.name)}",
                f"features = {{ F{i} = 1 }}", f"nominal = {_number(d.nominal)}", f"lower = {_number(d.lower)}",
                f"upper = {_number(d.upper)}"]
        if d.group:
            out.append(f"group = {_toml_string(d.group)}")
        out.append("")
    return "\n".join(out)
