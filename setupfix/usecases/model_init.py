"""Use case "model init": a process-model scaffold from CMM reports, drawn from their own geometry.

Every toleranced length characteristic of the reports becomes a dimension (its name,
nominal and limits as the report states them, ``group`` = the report's station, or its
part with ``parts_are_stations``), entered by the features below; the relations are
written from what the report states (:mod:`setupfix.outputs.model_toml`):

* the axis or direction a characteristic is measured along — first the report's (the
  ``axis`` column and the measuring direction ``nx, ny, nz`` of :mod:`parsers.geometry`:
  a DMIS ``CORTOL`` axis word or point normal, a QIF ``Direction``, ``AnalysisVector``
  or surface normal, a CALYPSO ``xValue``, a PC-DMIS axis letter), else the one its name
  states (a token ``X``, ``Y`` or ``Z``: ``SP_00_Z``, ``Cono_9_X``, ``Distanz X 4mm``).
  When both state one and they differ, the report's wins and the comment names both;
* sizes (diameter, radius, width, the length of a slot) as the report states them, with
  its feature type (circle, cylinder, slot … cut by interpolation: a tool radius moves
  them; others: nothing does) and side (bore or boss);
* the feature's nominal location as its ``position``.

A report that names its features (``feature_id``, ``between``), measures several axes, has
interpolated sizes or position callouts gets a multi-axis model (one feature per feature of
the part, :func:`plan_features`: a location follows its feature, a distance is the
difference of its two, a size moves with a tool radius only, a position callout is a
zone); any other a one-axis model on the axis it states.  ``axis=`` keeps one axis (and
the characteristics whose axis neither tells) in a one-axis model.  A multi-axis
scaffold's features carry named questions (which work offset and tool made each) until
``model map`` answers them, or the ``answers`` given here do.  Every scaffold is
``draft = true``: nothing is recommended from it until the user has checked its physics
and removed the key.

Left out, each listed in the file's head with its reason: reference-only rows, rows
with no limit or only one (the contract needs both; none is invented), form and
orientation tolerances (flatness, perpendicularity, … by name: no offset moves them),
values outside the model's sanity ranges, and other axes with ``axis=``.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

import parsers
from parsers.axes import AXES, AXIS_COLUMN, vector_axis
from parsers.geometry import DIRECTION_COLUMNS, FEATURE_COLUMN, SIDE_COLUMN, SIZE_COLUMN, unit_vector
from setupfix.core.errors import ModelError, Note, ParseError, SetupfixError, SourceLocation
from setupfix.inputs.cycles import ReadOptions
from setupfix.model import normalise_name
from setupfix.model.loader import RANGES_MM
from setupfix.model.measurements import (
    BETWEEN_COLUMN,
    CALLOUT_COLUMN,
    FEATURE_DIRECTION_COLUMNS,
    FEATURE_ID_COLUMN,
)
from setupfix.outputs.model_toml import SPINDLE, ScaffoldDimension, ScaffoldFeature, comment, render_scaffold
from setupfix.usecases.model_map import Answer, answer_text

__all__ = [
    "Scaffold",
    "scaffold_model",
    "scaffold_from_tables",
    "name_axis",
    "plan_features",
    "FORM_WORDS",
    "RowGeometry",
]

#: Words naming a form or orientation tolerance (English, German, Korean): no setup offset moves them.
FORM_WORDS = (
    "flatness",
    "straightness",
    "roundness",
    "circularity",
    "cylindricity",
    "sphericity",
    "parallelism",
    "perpendicularity",
    "angularity",
    "runout",
    "concentricity",
    "symmetry",
    "ebenheit",
    "geradheit",
    "rundheit",
    "zylindrizität",
    "parallelität",
    "rechtwinkligkeit",
    "neigung",
    "lauf",
    "평면도",
    "진원도",
    "진직도",
    "원통도",
    "평행도",
    "직각도",
    "경사도",
    "흔들림",
    "동심도",
)
_TOKENS = re.compile(r"[\s_.\-/:;,()\[\]#]+")


def name_axis(name: str) -> str | None:
    """The axis a characteristic's name states: the one token ``X``, ``Y`` or ``Z`` (any case), else None."""
    axes = {t.upper() for t in _TOKENS.split(name) if t.upper() in ("X", "Y", "Z")}
    return axes.pop() if len(axes) == 1 else None


def _is_form(name: str) -> bool:
    folded = name.casefold()
    return any(word in folded for word in FORM_WORDS)


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
    #: ``process.axes`` of a multi-axis scaffold (the axes the reports measure); () for a one-axis one.
    axes: tuple[str, ...] = ()
    #: How many dimensions are sizes (diameters, widths, …) as the reports state them.
    sizes: int = 0
    #: How many are position zones, and distances between two features.
    zones: int = 0
    distances: int = 0
    #: The named questions a multi-axis scaffold leaves (``Q1`` …): which WKS and tool made each feature.
    questions: tuple[str, ...] = ()


def _resolution(narrowest: float | None) -> float:
    """0.001 mm, finer by powers of ten until it is at most half the narrowest tolerance band."""
    res = 0.001
    while narrowest is not None and res > narrowest / 2 and res > RANGES_MM["resolution"][0]:
        res /= 10
    return res


#: Words of a characteristic's name that say it is a distance between two features (English, German,
#: Spanish, Italian, Korean), used where the report states no callout type and no features.
DISTANCE_WORDS = ("distance", "distanz", "abstand", "distancia", "distanza", "거리")
#: Words of a name that say it is a position callout (a one-sided zone value).
POSITION_WORDS = ("position", "posizione", "posición", "위치도")


@dataclass(frozen=True)
class RowGeometry:
    """What one report row states about its geometry (:mod:`parsers.geometry`, the position columns)."""

    direction: tuple[float, float, float] | None = None
    size: str = ""
    feature: str = ""
    side: str = ""
    position: tuple[float, float, float] | None = None
    feature_id: str = ""
    between: tuple[str, ...] = ()
    callout: str = ""
    feature_axis: tuple[float, float, float] | None = None


def _geometry(table: pd.DataFrame) -> list[RowGeometry]:
    """Per row: what the report states of its geometry, None / "" where it states nothing."""
    n = len(table)

    def numbers(name: str) -> list[float]:
        if name not in table:
            return [math.nan] * n
        return pd.to_numeric(table[name], errors="coerce").astype(float).tolist()

    def words(name: str, fold: bool = True) -> list[str]:
        if name not in table:
            return [""] * n
        return [(str(v).strip().lower() if fold else str(v).strip()) if isinstance(v, str) else "" for v in table[name]]

    def point(x: float, y: float, z: float) -> tuple[float, float, float] | None:
        return (x, y, z) if all(math.isfinite(v) for v in (x, y, z)) else None

    out = []
    for nx, ny, nz, size, feature, side, x, y, z, fid, between, callout, fx, fy, fz in zip(
        *(numbers(c) for c in DIRECTION_COLUMNS),
        words(SIZE_COLUMN),
        words(FEATURE_COLUMN),
        words(SIDE_COLUMN),
        numbers("x"),
        numbers("y"),
        numbers("z"),
        words(FEATURE_ID_COLUMN, fold=False),
        words(BETWEEN_COLUMN, fold=False),
        words(CALLOUT_COLUMN),
        *(numbers(c) for c in FEATURE_DIRECTION_COLUMNS),
        strict=True,
    ):
        ends = tuple(e.strip() for e in between.split(";") if e.strip()) if between else ()
        out.append(
            RowGeometry(
                unit_vector((nx, ny, nz)),
                size,
                feature,
                side,
                point(x, y, z),
                fid,
                ends,
                callout,
                unit_vector((fx, fy, fz)),
            )
        )
    return out


def _measures(name: str, row: RowGeometry, lower: float, upper: float) -> str:
    """What a row measures (:data:`~setupfix.outputs.model_toml.MEASURES`): the report's callout type first,
    then its ``between`` features, then the words of its name."""
    folded = name.casefold()
    one_sided = (math.isnan(lower) or lower == 0.0) and math.isfinite(upper) and upper > 0.0
    if row.size:
        return "size"
    if row.callout == "position" or (not row.callout and one_sided and any(w in folded for w in POSITION_WORDS)):
        return "position"
    if row.callout == "distance" or len(row.between) == 2:
        return "distance"
    if not row.callout and any(w in folded for w in DISTANCE_WORDS):
        return "distance"
    return "location"


def _collect(
    tables: Sequence[tuple[str, pd.DataFrame]], axis: str | None, group_column: str = "station"
) -> tuple[list[ScaffoldDimension], list[tuple[str, str]]]:
    dims: dict[tuple[str, str | None], ScaffoldDimension] = {}
    skipped: dict[str, str] = {}
    nom_lo, nom_hi = RANGES_MM["nominal"]
    tol_lo, tol_hi = RANGES_MM["tolerance"]
    for report, table in tables:
        count = len(table)

        def col(name: str, rows: int = count, frame: pd.DataFrame = table) -> list[Any]:
            return frame[name].tolist() if name in frame else [None] * rows

        for name, nominal, lower, upper, station, reference, where, stated, geometry in zip(
            col("characteristic"),
            col("nominal"),
            col("lower"),
            col("upper"),
            col(group_column),
            col("reference"),
            col("source"),
            col(AXIS_COLUMN),
            _geometry(table),
            strict=True,
        ):
            name = str(name).strip()
            if not name or name in skipped:
                continue
            where = str(where) if where is not None and where == where else report
            direction, size, feature, side, position = (
                geometry.direction,
                geometry.size,
                geometry.feature,
                geometry.side,
                geometry.position,
            )
            from_report = _stated_axis(stated, where, report) or (vector_axis(direction) or None if direction else None)
            from_name = None if size else name_axis(name)
            dim_axis = from_report or from_name
            nominal, lower, upper = (
                float(v) if v is not None and v == v else math.nan for v in (nominal, lower, upper)
            )
            measures = _measures(name, geometry, lower, upper)
            reason = None
            if str(reference).strip().lower() in ("true", "1", "yes"):
                reason = "reference only"
            elif measures == "position" and axis is not None:
                reason = f"a position callout: its circular zone needs a multi-axis model (--axis {axis})"
            elif measures == "position":
                if _is_form(name) or not (tol_lo <= 0.0 < upper <= 2 * tol_hi):
                    reason = "one-sided tolerance"
                else:
                    lower, nominal = 0.0, 0.0  # the zone's value is a distance from the true position
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
                dims[key] = ScaffoldDimension(
                    name,
                    group,
                    nominal,
                    lower,
                    upper,
                    dim_axis,
                    where,
                    "report" if from_report else "name" if from_name else "",
                    from_name if from_report and from_name not in (None, from_report) else None,
                    direction,
                    size,
                    feature,
                    side,
                    position,
                    measures,
                    geometry.feature_id,
                    geometry.between,
                    geometry.feature_axis,
                )
                continue
            known = dims[key]
            known.feature_id = known.feature_id or geometry.feature_id
            known.between = known.between or geometry.between
            known.feature_axis = known.feature_axis or geometry.feature_axis
            known.size, known.feature, known.side = known.size or size, known.feature or feature, known.side or side
            known.position = known.position or position
            if direction is not None and known.direction is None:
                known.direction = direction
            elif (
                direction is not None
                and known.direction is not None
                and any(abs(a - b) > 1e-6 for a, b in zip(direction, known.direction, strict=True))
            ):
                known.direction = None  # two reports state different directions: neither is taken
                known.axis_from, known.axis = "the reports state different directions", None
            if from_report and known.axis_from == "report" and known.axis != from_report:
                # two reports state different axes for one dimension: neither is taken
                known.axis_from, known.axis = f"the reports state {known.axis} and {from_report}", None
                known.direction = None
            elif from_report and known.axis_from in ("", "name") and axis in (None, from_report):
                known.name_says = from_name if from_name not in (None, from_report) else None
                known.axis, known.axis_from = from_report, "report"
    return list(dims.values()), list(skipped.items())


def _dominant(vector: tuple[float, float, float]) -> int:
    return max(range(3), key=lambda k: abs(vector[k]))


def plan_features(dims: Sequence[ScaffoldDimension]) -> list[ScaffoldFeature]:
    """The model features of a multi-axis scaffold, and each dimension's ``weights`` on them (in place).

    One location feature per feature of the part the reports name (``feature_id``; a
    characteristic naming none has one of its own), at its nominal position: a location
    enters it with weight 1 along its direction; a distance between two named features
    is their difference, signed so that it grows as they part along its direction (a
    work offset moving both alike cancels); a position callout is a zone on it.  A size
    gets a feature of its own (a tool radius moves the size, not the location), sharing
    its part feature's question.  Every feature an offset could move gets a named
    question (``Q1`` …): the reports never say which work offset and tool made it.
    """
    features: list[ScaffoldFeature] = []
    located: dict[tuple[str, str], ScaffoldFeature] = {}
    # a feature is the report's feature at one station: the same name at two stations is two workpieces
    known = {(d.group or "", d.feature_id): d for d in dims if d.feature_id}
    questions: dict[tuple[str, str], str] = {}

    def ask(key: tuple[str, str]) -> str:
        return questions.setdefault(key, f"Q{len(questions) + 1}")

    def location(key: tuple[str, str], label: str, d: ScaffoldDimension | None) -> ScaffoldFeature:
        if key not in located:
            source = d or known.get(key)
            located[key] = ScaffoldFeature(
                f"F{len(features) + 1}",
                label,
                source.position if source else None,
                source.feature if source else "",
                question=ask(key),
            )
            features.append(located[key])
        found = located[key]
        if found.position is None and d is not None:
            found.position = d.position
        found.kind = found.kind or (d.feature if d else "")
        return found

    by_axis = {
        (d.group or "", d.feature_id, d.axis): d.name
        for d in dims
        if d.measures == "location" and d.feature_id and d.axis
    }
    for d in dims:
        # a characteristic naming no feature: a feature of its own
        key = (d.group or "", d.feature_id or f"{d.name}\x00")
        label = d.feature_id or d.name
        if d.measures == "size":
            weight = d.radius_weight() if d.interpolated else None
            size = ScaffoldFeature(
                f"F{len(features) + 1}",
                label,
                d.position,
                d.feature,
                "size",
                weight,
                ask(key) if weight is not None else "",
                comment=(
                    f"its {d.size}: only a tool radius moves it"
                    + (
                        f" ({d.side or 'inner'} side{'' if d.side else ' assumed'})"
                        if weight is not None
                        else (
                            ": the report does not say it is cut by interpolation, so no offset moves it"
                            if d.feature
                            else " of a feature of no stated type (drilled or reamed?): no offset moves it"
                        )
                    )
                ),
            )
            size.callouts.append(d.name)
            features.append(size)
            d.weights = {size.id: 1.0}
        elif d.measures == "position":
            f = location(key, label, d)
            f.callouts.append(d.name)
            d.weights = {f.id: 1.0}
            if d.feature_axis is not None:
                k = _dominant(d.feature_axis)
                d.plane = tuple(a for j, a in enumerate(AXES) if j != k)  # type: ignore[assignment]  # two axes
                across = f"the plane across its feature's axis {AXES[k]}"
            else:
                d.plane = tuple(a for a in AXES if a != SPINDLE)  # type: ignore[assignment]  # two axes
                across = f"the report states no axis of its feature: one along the spindle ({SPINDLE}) assumed"
            rows = tuple(by_axis.get((d.group or "", d.feature_id, a), "") for a in d.plane)
            if d.feature_id and all(rows):
                d.components = rows  # type: ignore[assignment]  # two names
                d.why = f"{across}; components: the report's own {'/'.join(d.plane)} rows of {d.feature_id}"
            else:
                d.components = (f"{d.name} {d.plane[0]}", f"{d.name} {d.plane[1]}")
                d.why = (
                    f"{across}; the report gives the zone's value only: 'correct' leaves it out until a report "
                    f"gives its signed {'/'.join(d.plane)} deviations in the zone's datum frame as these components"
                )
        elif d.measures == "distance" and len(d.between) == 2:
            a, b = (location((d.group or "", e), e, None) for e in d.between)
            a.callouts.append(d.name)
            b.callouts.append(d.name)
            vec = d.vector()
            if vec is None and a.position is not None and b.position is not None:
                apart = [q - p for p, q in zip(a.position, b.position, strict=True)]
                vec = unit_vector(apart)
                d.direction = vec
                d.axis = vector_axis(vec) or None if vec is not None else None
            if vec is not None and a.position is not None and b.position is not None:
                grows = sum(v * (q - p) for v, p, q in zip(vec, a.position, b.position, strict=True))
                d.weights = {a.id: 1.0, b.id: -1.0} if grows < 0 else {b.id: 1.0, a.id: -1.0}
                d.why = f"the difference of {comment(d.between[0])} and {comment(d.between[1])}"
            else:
                d.weights = {b.id: 1.0, a.id: -1.0}
                d.why = (
                    f"the difference of {comment(d.between[1])} and {comment(d.between[0])} in the report's order "
                    "(their positions do not give its sign: check it)"
                )
        elif d.measures == "distance":
            d.weights = {}
            d.why = (
                "the report does not say between which features: as written no offset moves it (right when both "
                "ends are cut in one setup by one tool); else give features = { Fa = 1, Fb = -1 }"
            )
        elif d.vector() is None:
            d.weights = {}
            d.why = "no axis or direction stated: give it axis = … and features = { F… = 1 }"
        else:
            f = location(key, label, d)
            f.callouts.append(d.name)
            d.weights = {f.id: 1.0}
    # a size feature whose part feature is located shares its question; others keep their own
    return features


def scaffold_model(
    reports: Sequence[str | Path],
    *,
    axis: str | None = None,
    name: str | None = None,
    parts_are_stations: bool = False,
    read: ReadOptions | None = None,
    answers: Sequence[Answer] = (),
) -> Scaffold:
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
        raise ParseError(
            "folder holds no report file",
            location=SourceLocation(inputs.empty[0]),
            hint="; ".join(inputs.warnings()[:3]) or None,
        )
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
        raise ParseError(
            f"no file of {', '.join(map(str, reports))} is a readable report",
            location=SourceLocation(str(reports[0])),
            hint=str(left_out[0]) if left_out else None,
        )
    scaffold = scaffold_from_tables(
        [(r, read.table) for r, read in reads],
        axis=axis,
        name=name,
        parts_are_stations=parts_are_stations,
        answers=answers,
    )
    return dataclasses.replace(
        scaffold, notes=(*left_out, *(n for _, read in reads for n in read.notes), *scaffold.notes)
    )


def scaffold_from_tables(
    tables: Sequence[tuple[str, pd.DataFrame]],
    *,
    axis: str | None = None,
    name: str | None = None,
    parts_are_stations: bool = False,
    answers: Sequence[Answer] = (),
) -> Scaffold:
    """:func:`scaffold_model` on canonical tables already read, as (report name, table) pairs.

    ``parts_are_stations``: the report's parts are the fixture's stations (one workpiece
    per part, names repeating): ``group`` = the part, instead of the report's station.
    ``answers``: the questions of a multi-axis scaffold answered at once, as ``model map``
    would (:func:`setupfix.usecases.model_map.answer_text`; the scaffold stays a draft).
    """
    if axis is not None and axis not in ("X", "Y", "Z"):
        raise ModelError(f'axis must be "X", "Y" or "Z", got {axis!r}')
    reports = [r for r, _ in tables]
    dims, skipped = _collect(tables, axis, "part" if parts_are_stations else "station")
    if not dims:
        reasons = Counter(reason for _, reason in skipped)
        why = "; ".join(f"{n} × {r}" for r, n in reasons.most_common(4)) or "the reports hold no characteristic"
        raise ModelError(
            f"no toleranced length characteristic to make a dimension of ({why})",
            location=SourceLocation(", ".join(reports)),
        )
    stated = Counter(d.axis for d in dims if d.axis)
    zones = any(d.measures == "position" for d in dims)
    features: list[ScaffoldFeature] = plan_features(dims) if axis is None else []
    measured = set().union(*(d.measured_axes() for d in dims))
    interpolated = any(d.interpolated for d in dims)
    axes: tuple[str, ...] = ()
    named = any(d.feature_id or d.between for d in dims)  # the reports name the part's features
    if axis is None and (len(measured) >= 2 or interpolated or zones or named):
        axes = tuple(a for a in AXES if a in measured or (interpolated and a == SPINDLE))
    else:
        for d in dims:  # a one-axis scaffold: a feature per dimension
            d.weights, d.why = {}, ""
        features = []
    model_axis = axis or (SPINDLE if axes else max(("Z", "X", "Y"), key=lambda a: stated[a]))  # Z on a tie / none
    bands = [d.upper - d.lower for d in dims]
    resolution = _resolution(min(bands))
    text = render_scaffold(
        dims,
        skipped,
        reports,
        axis=model_axis,
        axes=axes,
        resolution=resolution,
        name=name,
        only_axis=axis,
        features=features,
    )
    questions = tuple(dict.fromkeys(f.question for f in features if f.question))
    notes: tuple[Note, ...] = ()
    if answers and not questions:
        notes = (
            Note(
                "answers given, but the scaffold asks no question (a one-axis scaffold moves each feature by W1): "
                "left unused",
                SourceLocation(", ".join(reports)),
                "answers",
            ),
        )
    elif answers:
        answered = answer_text(text, ", ".join(reports), answers, keep_draft=True)
        text, questions = answered.text, answered.remaining
    origins = Counter(
        d.axis_from if d.axis_from in ("report", "name") else "none" for d in dims if d.measures != "position"
    )
    return Scaffold(
        text,
        len(dims),
        model_axis,
        tuple(skipped),
        axes_from={k: origins[k] for k in ("report", "name", "none") if origins[k]},
        axes=axes,
        sizes=sum(1 for d in dims if d.size),
        zones=sum(1 for d in dims if d.measures == "position") if axes else 0,
        distances=sum(1 for d in dims if d.measures == "distance"),
        questions=questions,
        notes=notes,
    )
