"""Measured parts tied to the process model.

The canonical measurement table (``../shared/spec/measurements.md``) is a
:class:`pandas.DataFrame` with the columns of :data:`CANONICAL_COLUMNS`; every reader
in :mod:`parsers` produces it with lengths in millimetres and a ``source`` column
giving the provenance of each row (``file:line`` or ``file#element``).

:func:`match_parts` splits such a table into parts (fixture cycles) and ties each
characteristic to a model dimension by name or alias, ignoring case and white
space.  A dimension that a report does not contain is *absent*: it is left out of
the objective and listed, never guessed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

import numpy as np
import numpy.typing as npt
import pandas as pd

from setupfix.errors import MatchError, SourceLocation
from setupfix.model.process import ProcessModel, normalise_name
from setupfix.units import length_factor


__all__ = ["CANONICAL_COLUMNS", "LENGTH_COLUMNS", "PartMeasurement", "match_parts"]

#: Columns of the canonical measurement table, in the order writers emit them.
CANONICAL_COLUMNS: Final[tuple[str, ...]] = (
    "characteristic", "nominal", "actual", "deviation", "lower", "upper", "unit",
    "part", "report", "timestamp", "station", "x", "y", "z", "status", "source",
)

#: Columns holding lengths (converted between units together).
LENGTH_COLUMNS: Final[tuple[str, ...]] = ("nominal", "actual", "deviation", "lower", "upper", "x", "y", "z")


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
    """

    part: str
    report: str
    timestamp: str | None
    deviation: npt.NDArray[np.float64]
    sources: tuple[str, ...]
    unmatched: tuple[str, ...] = ()
    absent: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())

    @property
    def measured(self) -> npt.NDArray[np.bool_]:
        """Mask of the dimensions present in the report, shape (n_dimensions,)."""
        return ~np.isnan(self.deviation)


def _lookup(model: ProcessModel) -> dict[str, list[tuple[int, str | None]]]:
    table: dict[str, list[tuple[int, str | None]]] = {}
    for i, dim in enumerate(model.dimensions):
        for key in dim.keys:
            table.setdefault(key, []).append((i, dim.group))
    return table


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
        If no characteristic of a part matches any model dimension, if one
        dimension is measured twice in one part, or if a repeated name cannot be
        told apart by station.
    """
    if table.empty:
        raise MatchError("the report holds no measured characteristic", location=SourceLocation(source))
    lookup = _lookup(model)
    n = len(model.dimensions)
    # Plain per-column lists: row access through DataFrame.iterrows costs ~50 µs a row,
    # which dominated the reading of large multi-part reports.
    count = len(table)
    names = table["characteristic"].astype(str).tolist()
    values = pd.to_numeric(table["deviation"], errors="coerce").to_numpy(dtype=float)
    wheres = [_text(w) or source for w in _column(table, "source", count)]
    stations = [_text(v) for v in _column(table, "station", count)]
    units = [_text(v) or "mm" for v in _column(table, "unit", count)]
    part_of = [_text(v) or "" for v in _column(table, "part", count)]
    reports = _column(table, "report", count)
    stamps = _column(table, "timestamp", count)
    rows_of: dict[str, list[int]] = {}
    for i, key in enumerate(part_of):
        rows_of.setdefault(key, []).append(i)
    factors = {u: length_factor(u, model.unit) for u in set(units)}
    parts: list[PartMeasurement] = []
    for key, rows in rows_of.items():
        deviation = np.full(n, np.nan)
        sources = [""] * n
        unmatched: list[str] = []
        for i in rows:
            name, where = names[i], wheres[i]
            candidates = lookup.get(normalise_name(name), [])
            station = stations[i]
            if len(candidates) > 1:
                candidates = [c for c in candidates if station is not None and c[1] is not None
                              and normalise_name(c[1]) == normalise_name(station)]
                if len(candidates) != 1:
                    raise MatchError(
                        f"characteristic {name!r} names several dimensions; give a station matching their group",
                        location=SourceLocation(where),
                    )
            if not candidates:
                unmatched.append(name)
                continue
            idx = candidates[0][0]
            value = float(values[i]) * factors[units[i]]
            if not np.isfinite(value):
                raise MatchError(f"characteristic {name!r} has no measured value", location=SourceLocation(where))
            if not np.isnan(deviation[idx]):
                raise MatchError(
                    f"dimension {model.dimensions[idx].id} is measured twice in part {key or '(report)'} "
                    f"(also at {sources[idx]})",
                    location=SourceLocation(where),
                )
            deviation[idx] = value
            sources[idx] = where
        if np.isnan(deviation).all():
            raise MatchError(
                f"no characteristic of part {key or '(report)'} matches a model dimension"
                + (f" (report names e.g. {', '.join(repr(u) for u in unmatched[:3])})" if unmatched else ""),
                location=SourceLocation(source),
                hint="check the dimension names and aliases in the model",
            )
        first = rows[0]
        parts.append(
            PartMeasurement(
                part=key,
                report=_text(reports[first]) or source,
                timestamp=_text(stamps[first]),
                deviation=deviation,
                sources=tuple(sources),
                unmatched=tuple(dict.fromkeys(unmatched)),
                absent=tuple(d.id for d, v in zip(model.dimensions, deviation) if np.isnan(v)),
            )
        )
    return parts


def _column(table: pd.DataFrame, name: str, count: int) -> list[object]:
    """Values of an optional column as a list (all None when the column is missing)."""
    return table[name].tolist() if name in table else [None] * count


def _text(value: object) -> str | None:
    """A cell as text, None when it is empty or missing (None, NaN, "")."""
    if value is None or (isinstance(value, float) and value != value):
        return None
    text = str(value)
    return text if text != "" else None
