"""Measured parts tied to the process model.

The canonical measurement table (``../shared/spec/measurements.md``) is a
:class:`pandas.DataFrame` with the columns of :data:`CANONICAL_COLUMNS`; every reader
in :mod:`parsers` produces it with lengths in millimetres and a ``source`` column
giving the provenance of each row (``file:line`` or ``file#element``).

:func:`match_parts` splits such a table into parts (fixture cycles) and ties each
characteristic to a model dimension by name or alias, ignoring case and white
runs of white space (``"P1  d4"`` matches ``"P1 D4"``; ``"P1D4"`` does not, but is
suggested).  A dimension that a report does not contain is *absent*: it is left out
of the objective and listed, never guessed.  A characteristic that matches no
dimension is listed with the closest model names (:func:`suggest_names`).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Final

import numpy as np
import numpy.typing as npt
import pandas as pd

from setupfix.core.errors import MatchError, Note, SourceLocation
from setupfix.core.units import length_factor
from setupfix.model.process import Dimension, ProcessModel, normalise_name

__all__ = [
    "CANONICAL_COLUMNS",
    "LENGTH_COLUMNS",
    "ACTUAL_POSITION_COLUMNS",
    "FEATURE_DIRECTION_COLUMNS",
    "FEATURE_ID_COLUMN",
    "BETWEEN_COLUMN",
    "DATUMS_COLUMN",
    "CALLOUT_COLUMN",
    "CALLOUTS",
    "UNCERTAINTY_COLUMN",
    "OPTIONAL_LENGTH_COLUMNS",
    "GEOMETRY_OUTPUT_COLUMNS",
    "PartMeasurement",
    "match_parts",
    "match_reports",
    "suggest_names",
    "closest_names",
    "did_you_mean",
    "report_names",
]

#: Columns of the canonical measurement table, in the order writers emit them.
CANONICAL_COLUMNS: Final[tuple[str, ...]] = (
    "characteristic",
    "nominal",
    "actual",
    "deviation",
    "lower",
    "upper",
    "unit",
    "part",
    "report",
    "timestamp",
    "station",
    "x",
    "y",
    "z",
    "status",
    "source",
)

#: Columns holding lengths (converted between units together).
LENGTH_COLUMNS: Final[tuple[str, ...]] = ("nominal", "actual", "deviation", "lower", "upper", "x", "y", "z")

# The optional columns of the geometry and the uncertainty a report states per row (issues 39, 40).
# The contract keeps columns beyond the canonical ones; a reader that cannot state one leaves it NaN / "".
#: Measured location of the row's feature (the same point of it as ``x, y, z`` nominally).
ACTUAL_POSITION_COLUMNS: Final[tuple[str, ...]] = ("x_actual", "y_actual", "z_actual")
#: The feature's own nominal direction, a unit vector: a cylinder's or cone's axis, a plane's, point's or
#: circle's normal, a line's direction (``nx, ny, nz`` is the direction the *value* is measured along).
FEATURE_DIRECTION_COLUMNS: Final[tuple[str, ...]] = ("feature_nx", "feature_ny", "feature_nz")
#: The name of the feature the row measures ("" for a characteristic of several features).
FEATURE_ID_COLUMN: Final = "feature_id"
#: The features a distance or angle is measured between, ``"id1;id2"`` in the report's order.
BETWEEN_COLUMN: Final = "between"
#: The datum reference frame, ``"A|B|C"`` in precedence order (a compound datum ``"A-B"``).
DATUMS_COLUMN: Final = "datums"
#: What the characteristic is, as the report's own type says it: ``"distance"`` (between features),
#: ``"angle"`` (between features) or ``"position"`` (a true-position value); ``""`` when not stated.
CALLOUT_COLUMN: Final = "callout"
#: The words of :data:`CALLOUT_COLUMN`.
CALLOUTS: Final[tuple[str, ...]] = ("distance", "angle", "position")
#: Expanded measurement uncertainty U (k = 2) of the row's result, a length in the row's unit.
UNCERTAINTY_COLUMN: Final = "uncertainty"
#: Optional columns holding lengths: converted with the row's unit when present.
OPTIONAL_LENGTH_COLUMNS: Final[tuple[str, ...]] = (*ACTUAL_POSITION_COLUMNS, UNCERTAINTY_COLUMN)
#: The optional columns ``setupfix parse`` writes after the canonical ones, in this order, when a report
#: states them (``nx … side`` are :mod:`parsers.geometry`'s).
GEOMETRY_OUTPUT_COLUMNS: Final[tuple[str, ...]] = (
    *ACTUAL_POSITION_COLUMNS,
    "nx",
    "ny",
    "nz",
    *FEATURE_DIRECTION_COLUMNS,
    "feature",
    "size",
    "side",
    FEATURE_ID_COLUMN,
    BETWEEN_COLUMN,
    DATUMS_COLUMN,
    CALLOUT_COLUMN,
    UNCERTAINTY_COLUMN,
)


@dataclass(frozen=True)
class PartMeasurement:
    """One measured part (one fixture cycle) in the model's terms.

    Attributes
    ----------
    part : str
        Part / cycle identifier.
    report : str
        Source report identifier.
    timestamp : str or None
        When the part was machined (ISO 8601), if the report says.
    deviation : ndarray of shape (n_dimensions,) [model unit]
        Measured deviation (actual − nominal) of each model dimension, in model
        order; NaN where the dimension is absent from the report.
    sources : tuple of str
        Provenance of each dimension's row ("" where absent).
    unmatched : tuple of str
        Characteristic names of the report that match no dimension.
    absent : tuple of str
        IDs of model dimensions the report does not contain.
    notes : tuple of Note
        What matching assumed (a dimension measured twice, …) and, after
        :func:`setupfix.inputs.checks.check_parts`, how the report differs from the model.
    nominal, lower, upper : ndarray of shape (n_dimensions,) [model unit]
        The report's own nominal and limits of each matched dimension (NaN where
        absent or not given), kept to check the report against the model.
    units : tuple of str
        The unit each matched row was labelled with ("" where absent).
    suggestions : dict
        Each unmatched name → the closest model dimension names, best first.
    stations : tuple of str
        The parts (or stations) merged into this cycle, in report order.
    names : tuple of str
        The report's characteristic name matched to each dimension ("" where absent).
    zone : ndarray of shape (n_dimensions, 2) or None
        A multi-axis model's position zones: the signed deviations of each zone's two
        component characteristics (along its plane axes, model unit); NaN for every other
        dimension.  ``deviation`` holds the zone's radial distance ‖(δ1, δ2)‖.  None when the
        model has no zone.
    uncertainty : ndarray of shape (n_dimensions,) [model unit] or None
        The report's expanded uncertainty U (k = 2) of each matched dimension's row
        (:data:`UNCERTAINTY_COLUMN`); NaN where absent, not given or a position zone (whose
        components' U do not add up to the zone's).  None when not read from a table.
    """

    part: str
    report: str
    timestamp: str | None
    deviation: npt.NDArray[np.float64]
    sources: tuple[str, ...]
    unmatched: tuple[str, ...] = ()
    absent: tuple[str, ...] = ()
    notes: tuple[Note, ...] = field(default=())
    nominal: npt.NDArray[np.float64] | None = None
    lower: npt.NDArray[np.float64] | None = None
    upper: npt.NDArray[np.float64] | None = None
    units: tuple[str, ...] = ()
    suggestions: dict[str, tuple[str, ...]] = field(default_factory=dict)
    stations: tuple[str, ...] = ()
    names: tuple[str, ...] = ()
    zone: npt.NDArray[np.float64] | None = None
    uncertainty: npt.NDArray[np.float64] | None = None

    @property
    def measured(self) -> npt.NDArray[np.bool_]:
        """Mask of the dimensions present in the report, shape (n_dimensions,)."""
        return ~np.isnan(self.deviation)


def _lookup(model: ProcessModel) -> dict[str, list[tuple[int, str | None, int]]]:
    """Normalised name → (dimension index, group, component): component −1 for a dimension's own name,
    0 or 1 for a position zone's component characteristic."""
    table: dict[str, list[tuple[int, str | None, int]]] = {}
    for i, dim in enumerate(model.dimensions):
        for key in dim.keys:
            table.setdefault(key, []).append((i, dim.group, -1))
        for k, key in enumerate(dim.component_keys):
            table.setdefault(key, []).append((i, dim.group, k))
    return table


def _take_row(
    model: ProcessModel,
    part: str,
    idx: int,
    row: int,
    value: float,
    row_of: list[int],
    deviation: npt.NDArray[np.float64],
    notes: list[Note],
    stamps: list[object],
    wheres: list[str],
    name: str,
) -> None:
    """Row ``row`` measures dimension ``idx``: the later of it and an earlier row wins, with a note."""
    if row_of[idx] >= 0:
        earlier = row_of[idx]
        where = wheres[row]
        dim = model.dimensions[idx].id
        if not _later(stamps[earlier], stamps[row]):
            notes.append(
                Note(
                    f"dimension {dim} ({name}) is measured twice in part {part or '(report)'}: the later "
                    f"measurement at {wheres[earlier]} is used, this one ignored",
                    SourceLocation(where),
                    "match",
                )
            )
            return
        notes.append(
            Note(
                f"dimension {dim} ({name}) is measured twice in part {part or '(report)'}: the later "
                f"measurement here is used, the one at {wheres[earlier]} ignored",
                SourceLocation(where),
                "match",
            )
        )
    deviation[idx] = value
    row_of[idx] = row


def match_parts(model: ProcessModel, table: pd.DataFrame, *, source: str = "<report>") -> list[PartMeasurement]:
    """Split a canonical measurement table into parts matched to the model.

    Parameters
    ----------
    model : ProcessModel
    table : DataFrame
        Canonical measurement table, lengths in the unit of its ``unit`` column
        (``mm`` where empty).
    source : str
        Name of the report, for messages.

    Returns
    -------
    list of PartMeasurement
        In order of first appearance of each part.

    Raises
    ------
    MatchError
        If no characteristic of a part matches any model dimension, or if a
        repeated name cannot be told apart by station.  A dimension measured twice
        in one part keeps the later measurement (time stamp, else file order) with
        a note.
    """
    if table.empty:
        raise MatchError("the report holds no measured characteristic", location=SourceLocation(source))
    cols = _Rows.of(model, table)
    return _match_slice(model, cols, 0, len(table), source, {})


def match_reports(
    model: ProcessModel, table: pd.DataFrame, starts: npt.NDArray[np.int64], sources: Sequence[str]
) -> list[list[PartMeasurement]]:
    """:func:`match_parts` of many reports stored one after another in one table, in one pass.

    Parameters
    ----------
    model : ProcessModel
    table : DataFrame
        The reports' canonical rows, each report's rows together, in report order.
    starts : ndarray of int, shape (n_reports,)
        The first row of each report (ascending; a report ends where the next one starts,
        the last at the table's end).  A report with no row (two equal starts) is refused
        as :func:`match_parts` refuses an empty table.
    sources : sequence of str, length n_reports
        Each report's name, for messages and as the default ``source`` of its rows.

    Returns
    -------
    list of list of PartMeasurement
        Per report, exactly what ``match_parts(model, table.iloc[a:b], source=sources[k])`` returns:
        the columns are converted once for the whole table instead of once per report.
    """
    bounds = np.r_[np.asarray(starts, dtype=np.int64), len(table)]
    cols = _Rows.of(model, table)
    suggestions: dict[str, tuple[str, ...]] = {}
    out: list[list[PartMeasurement]] = []
    for k, source in enumerate(sources):
        a, b = int(bounds[k]), int(bounds[k + 1])
        if a >= b:
            raise MatchError("the report holds no measured characteristic", location=SourceLocation(source))
        out.append(_match_slice(model, cols, a, b, source, suggestions))
    return out


@dataclass(frozen=True)
class _Rows:
    """A canonical table's columns as plain lists and arrays (row access through pandas costs ~50 µs a row)."""

    names: list[str]
    keys: list[str]
    values: npt.NDArray[np.float64]
    given: tuple[npt.NDArray[np.float64], ...]  # nominal, lower, upper, uncertainty
    sources: list[str | None]
    stations: list[str | None]
    station_keys: list[str | None]
    units: list[str]
    factors: dict[str, float]
    row_factor: npt.NDArray[np.float64]
    part_of: list[str]
    reports: list[object]
    stamps: list[object]
    lookup: dict[str, list[tuple[int, str | None, int]]]
    #: per row, the dimension its name alone names (no other dimension, no zone component), else -1
    single: npt.NDArray[np.int64]
    dim_ids: npt.NDArray[np.object_]
    zones: bool

    @classmethod
    def of(cls, model: ProcessModel, table: pd.DataFrame) -> _Rows:
        count = len(table)
        names = table["characteristic"].astype(str).tolist()
        normal = {name: normalise_name(name) for name in set(names)}
        stations = [_text(v) for v in _column(table, "station", count)]
        station_normal = {s: normalise_name(s) for s in set(stations) if s is not None}
        units = [_text(v) or "mm" for v in _column(table, "unit", count)]
        factors = {u: length_factor(u, model.unit) for u in set(units)}
        lookup = _lookup(model)
        one = {
            k: (f[0][0] if len(f) == 1 and f[0][2] < 0 else -1)
            for k in set(normal.values())
            if (f := lookup.get(k, []))
        }
        return cls(
            names=names,
            keys=[normal[name] for name in names],
            values=_numbers(table, "deviation", count),
            given=tuple(_numbers(table, c, count) for c in ("nominal", "lower", "upper", UNCERTAINTY_COLUMN)),
            sources=[_text(w) for w in _column(table, "source", count)],
            stations=stations,
            station_keys=[station_normal[s] if s is not None else None for s in stations],
            units=units,
            factors=factors,
            row_factor=np.array([factors[u] for u in units], dtype=float),
            part_of=[_text(v) or "" for v in _column(table, "part", count)],
            reports=_column(table, "report", count),
            stamps=_column(table, "timestamp", count),
            lookup=lookup,
            single=np.array([one.get(normal[name], -1) for name in names], dtype=np.int64),
            dim_ids=np.array([d.id for d in model.dimensions], dtype=object),
            zones=any(d.zone for d in model.dimensions),
        )


def _match_slice(
    model: ProcessModel, cols: _Rows, a: int, b: int, source: str, suggestions: dict[str, tuple[str, ...]]
) -> list[PartMeasurement]:
    """The parts of rows ``a:b`` of ``cols`` (one report, named ``source``) matched to the model.

    Row indices inside are relative to ``a``; ``suggestions`` caches :func:`suggest_names` across calls.
    """
    lookup = cols.lookup
    n = len(model.dimensions)
    names = cols.names[a:b]
    keys = cols.keys[a:b]
    values = cols.values[a:b]
    nominals, lowers, uppers, stated_u = (g[a:b] for g in cols.given)
    wheres = [w or source for w in cols.sources[a:b]]
    stations = cols.stations[a:b]
    station_keys = cols.station_keys[a:b]
    units = cols.units[a:b]
    factors = cols.factors
    row_factor = cols.row_factor[a:b]
    reports = cols.reports[a:b]
    stamps = cols.stamps[a:b]
    dim_ids = cols.dim_ids
    zones = cols.zones
    single = cols.single[a:b]
    rows_of: dict[str, list[int]] = {}
    for i, key in enumerate(cols.part_of[a:b]):
        rows_of.setdefault(key, []).append(i)
    parts: list[PartMeasurement] = []
    for key, rows in rows_of.items():
        deviation = np.full(n, np.nan)
        zone = np.full((n, 2), np.nan)
        zone_rows: dict[tuple[int, int], int] = {}
        given = np.full((4, n), np.nan)
        row_of = [-1] * n  # the table row matched to each dimension
        unmatched: list[str] = []
        notes: list[Note] = []
        at = single[rows]
        scaled = values[rows] * row_factor[rows]
        at_once = bool((at >= 0).all() and np.unique(at).size == len(rows) and np.isfinite(scaled).all())
        if at_once:  # every row names one dimension by its own name, each dimension once: the loop below at once
            deviation[at] = scaled
            for q, i in zip(at.tolist(), rows, strict=True):
                row_of[q] = i
        for i in () if at_once else rows:
            name, where = names[i], wheres[i]
            found = lookup.get(keys[i], [])
            station = station_keys[i]
            # one row may be a dimension and a position zone's component at once (the model allows a name
            # once as each): each kind is told apart by station on its own, and the row feeds both
            chosen: list[tuple[int, str | None, int]] = []
            for candidates in ([c for c in found if c[2] < 0], [c for c in found if c[2] >= 0]):
                if len(candidates) > 1:
                    candidates = [
                        c
                        for c in candidates
                        if station is not None and c[1] is not None and normalise_name(c[1]) == station
                    ]
                    if len(candidates) != 1:
                        raise MatchError(
                            f"characteristic {name!r} names several dimensions; give a station matching their group",
                            location=SourceLocation(where),
                            hint="--stations P1,P2,… or --parts-per-cycle N",
                        )
                chosen += candidates
            if not chosen:
                unmatched.append(name)
                continue
            value = float(values[i]) * factors[units[i]]
            if not np.isfinite(value):
                raise MatchError(f"characteristic {name!r} has no measured value", location=SourceLocation(where))
            for idx, _, comp in chosen:
                if comp >= 0:  # a position zone's component: the later row wins, as for a dimension
                    if (idx, comp) in zone_rows and not _later(stamps[zone_rows[(idx, comp)]], stamps[i]):
                        continue
                    zone[idx, comp] = value
                    zone_rows[(idx, comp)] = i
                else:
                    _take_row(model, key, idx, i, value, row_of, deviation, notes, stamps, wheres, name)
        for (idx, comp), i in zone_rows.items():
            if not np.isnan(zone[idx]).any():
                deviation[idx] = float(np.hypot(zone[idx, 0], zone[idx, 1]))
                row_of[idx] = i
            elif comp == 0 or (idx, 0) not in zone_rows:
                dim = model.dimensions[idx]
                notes.append(
                    Note(
                        f"position zone {dim.id} ({dim.name}): only one of its components "
                        f"{dim.components[0]!r}, {dim.components[1]!r} is in part {key or '(report)'}; "
                        "the zone is left out",
                        SourceLocation(wheres[i]),
                        "match",
                    )
                )
        if np.isnan(deviation).all():
            raise MatchError(
                f"no characteristic of part {key or '(report)'} matches a model dimension"
                + (f" (report names e.g. {_examples(model, unmatched[:3])})" if unmatched else ""),
                location=SourceLocation(source),
                hint="check the dimension names and aliases in the model; 'setupfix model check MODEL REPORT' "
                "prints the match table",
            )
        matched = np.flatnonzero(np.asarray(row_of) >= 0)
        taken = np.asarray(row_of)[matched]
        for k, column in enumerate((nominals, lowers, uppers, stated_u)):
            given[k, matched] = column[taken] * row_factor[taken]
        given[:, [idx for idx, _ in zone_rows]] = np.nan  # a zone's limits are its diameter, not the rows'
        zone[np.isnan(deviation)] = np.nan
        unmatched = list(dict.fromkeys(unmatched))
        for name in unmatched:
            if name not in suggestions:
                suggestions[name] = suggest_names(model, name)
        first = rows[0]
        parts.append(
            PartMeasurement(
                part=key,
                report=_text(reports[first]) or source,
                timestamp=_text(stamps[first]),
                deviation=deviation,
                sources=tuple(wheres[i] if i >= 0 else "" for i in row_of),
                unmatched=tuple(unmatched),
                absent=tuple(dim_ids[np.isnan(deviation)].tolist()),
                notes=tuple(notes),
                nominal=given[0],
                lower=given[1],
                upper=given[2],
                units=tuple(units[i] if i >= 0 else "" for i in row_of),
                suggestions={name: suggestions[name] for name in unmatched},
                stations=tuple(dict.fromkeys(s for i in rows if (s := stations[i]) is not None)),
                names=tuple(
                    " + ".join(names[zone_rows[(q, k)]] for k in (0, 1))
                    if (q, 1) in zone_rows and i >= 0
                    else names[i]
                    if i >= 0
                    else ""
                    for q, i in enumerate(row_of)
                ),
                zone=zone if zones else None,
                uncertainty=given[3],
            )
        )
    return parts


_PUNCT = re.compile(r"[\W_]+")


def report_names(dimension: Dimension) -> tuple[str, ...]:
    """The names a report may give a dimension: its name and aliases, or a position zone's components."""
    return (*dimension.components,) if dimension.zone else (dimension.name, *dimension.aliases)


def closest_names(name: str, candidates: Iterable[str], n: int = 3) -> tuple[str, ...]:
    """The candidate names closest to ``name``, best first: the one rule of every name suggestion.

    Names equal but for white space, punctuation and case (``P1D1`` / ``P1 D1``,
    ``P1-D4`` / ``P1 D4``, ``SP_00_Z`` / ``SP-00_Z``) come first, then the closest by
    :func:`difflib.get_close_matches` (ratio ≥ 0.6) when there is no such name.
    """
    names = list(dict.fromkeys(candidates))
    skeleton = _PUNCT.sub("", name).casefold()
    exact = [m for m in names if _PUNCT.sub("", m).casefold() == skeleton] if skeleton else []
    if exact:
        return tuple(exact[:n])
    by_key = {normalise_name(m): m for m in names}
    close = difflib.get_close_matches(normalise_name(name), list(by_key), n=n, cutoff=0.6)
    return tuple(dict.fromkeys(by_key[c] for c in close))[:n]


def suggest_names(model: ProcessModel, name: str, n: int = 3) -> tuple[str, ...]:
    """The model dimension names (aliases, a zone's components) closest to a report's characteristic name
    (:func:`closest_names`)."""
    return closest_names(name, (n_ for d in model.dimensions for n_ in report_names(d)), n)


def did_you_mean(model: ProcessModel, part: PartMeasurement) -> dict[str, str]:
    """Unmatched report name → the absent dimension it most likely means (``P1-D4`` → ``P1 D4``).

    Only names of dimensions the part lacks are offered (a matched dimension is not what an
    unmatched name meant), by :func:`closest_names`: ``correct`` and ``model check`` alike.
    """
    absent = set(part.absent)
    names = [n_ for d in model.dimensions if d.id in absent for n_ in report_names(d)]
    out: dict[str, str] = {}
    for unmatched in part.unmatched:
        near = closest_names(unmatched, names, 1)
        if near:
            out[unmatched] = near[0]
    return out


def _examples(model: ProcessModel, unmatched: list[str]) -> str:
    parts = []
    for name in unmatched:
        near = suggest_names(model, name, n=1)
        parts.append(f"{name!r}" + (f" (model: {near[0]!r}?)" if near else ""))
    return ", ".join(parts)


def _later(earlier: object, later: object) -> bool:
    """Whether the row with time stamp ``later`` is the later measurement (file order on ties)."""
    a, b = _text(earlier), _text(later)
    if a is None or b is None or a == b:
        return True
    ta, tb = pd.to_datetime(a, errors="coerce"), pd.to_datetime(b, errors="coerce")
    if pd.isna(ta) or pd.isna(tb):
        return True
    return bool(tb >= ta)


def _numbers(table: pd.DataFrame, name: str, count: int) -> npt.NDArray[np.float64]:
    """An optional numeric column as floats (NaN where empty or missing)."""
    if name not in table:
        return np.full(count, np.nan)
    column = table[name]
    if column.dtype == np.float64:  # every reader's lengths: no conversion (0.1 ms a column)
        return column.to_numpy()
    return pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)


def _column(table: pd.DataFrame, name: str, count: int) -> list[object]:
    """Values of an optional column as a list (all None when the column is missing)."""
    return table[name].tolist() if name in table else [None] * count


def _text(value: object) -> str | None:
    """A cell as text, None when it is empty or missing (None, NaN, "")."""
    if value is None or (isinstance(value, float) and value != value):
        return None
    text = str(value)
    return text if text != "" else None
