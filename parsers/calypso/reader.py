"""Zeiss CALYPSO characteristics table (``*_chr.txt``) → the canonical table.

Layout as in ``../shared/cmm-samples/calypso/CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt``:
TAB-separated, one header row of column names, a literal ``END`` line at the end,
Latin-1/CP1252 text (German ``Lotlänge``).  Columns are found by header name because
customers add their own fields; data rows are ragged (the header names 45 columns +
a trailing TAB, rows stop after ``unit``), so a missing trailing cell is empty.
``uppertol``/``lowertol`` are signed offsets from nominal already.

The stable ``idsymbol`` states the geometry columns (:mod:`parsers.geometry`) where it
can: ``xValue``/``yValue``/``zValue`` a coordinate along that axis, ``diameter`` and
``radius`` a size; the table states no feature type (``featureid`` is a user's name).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pandas as pd

from parsers.canonical import DEVIATION_TOLERANCE_MM, finish_table
from parsers.geometry import axis_vector, geometry_cells
from parsers.numbers import parse_number
from parsers.source import csv_records, read_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS, length_factor
from setupfix.model.measurements import DATUMS_COLUMN, FEATURE_ID_COLUMN

__all__ = ["read_calypso", "sniff_calypso", "REQUIRED"]

#: ``idsymbol`` → (axis of a coordinate, size) it states.
_SYMBOLS = {
    "xvalue": ("X", ""),
    "yvalue": ("Y", ""),
    "zvalue": ("Z", ""),
    "diameter": ("", "diameter"),
    "radius": ("", "radius"),
}

#: Columns without which a row cannot be read.
REQUIRED = ("id", "actual", "nominal")


def sniff_calypso(text: str) -> bool:
    """True when the first line is a CALYPSO characteristics header. Never raises."""
    first = text.lstrip("\ufeff").split("\n", 1)[0]
    names = {c.strip().lower() for c in first.split("\t")}
    return {"planid", "id", "actual", "nominal", "idsymbol"} <= names


def _value(row: list[str], index: dict[str, int], column: str) -> str:
    i = index.get(column)
    return row[i].strip() if i is not None and i < len(row) else ""


def _length(text: str, column: str, where: SourceLocation) -> float:
    return parse_number(text, decimal="auto", location=where, what=f"column {column!r}", allow_empty=True)


def read_calypso(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a CALYPSO ``*_chr.txt`` table.

    Parameters
    ----------
    path : str or Path
        The table file.
    unit : {"mm", "inch"}, optional
        Unit of rows whose ``unit`` cell is empty (default mm).
    encoding : str, optional
        Text encoding; sniffed when omitted (CP1252 for the German samples).

    Raises
    ------
    ParseError
        On a missing required column, a non-numeric value, an unknown unit or a stated
        deviation that contradicts actual − nominal; names file and line.
    """
    name = str(path)
    records = csv_records(read_text(path, encoding), name, delimiter="\t", quoting=csv.QUOTE_NONE)
    try:
        header = [h.strip().lower() for h in next(records)[1]]
    except StopIteration:
        raise ParseError("empty file", location=SourceLocation(name, line=1)) from None
    index = {h: i for i, h in reversed(list(enumerate(header))) if h}
    missing = [c for c in REQUIRED if c not in index]
    if missing:
        raise ParseError(f"missing CALYPSO column(s): {', '.join(missing)}", location=SourceLocation(name, line=1))
    rows: list[dict[str, object]] = []
    for line, record in records:
        where = SourceLocation(name, line=line)
        if not any(cell.strip() for cell in record):
            continue
        if record[0].strip().upper() == "END" and not any(c.strip() for c in record[1:]):
            break
        label = _value(record, index, "id")
        if not label:
            raise ParseError("empty characteristic id", location=where)
        row_unit = (_value(record, index, "unit") or unit or "mm").lower()
        if row_unit not in LENGTH_UNITS:
            raise ParseError(f"unknown unit {row_unit!r} (expected mm or inch)", location=where)
        f = length_factor(row_unit, "mm")
        nominal = _length(_value(record, index, "nominal"), "nominal", where) * f
        actual = _length(_value(record, index, "actual"), "actual", where) * f
        if math.isnan(nominal) or math.isnan(actual):
            raise ParseError("a characteristic needs both actual and nominal", location=where)
        stated = _length(_value(record, index, "deviation"), "deviation", where) * f
        if not math.isnan(stated) and abs(stated - (actual - nominal)) > DEVIATION_TOLERANCE_MM:
            raise ParseError(
                f"deviation {stated:g} mm contradicts actual - nominal = {actual - nominal:g} mm", location=where
            )
        upper = _length(_value(record, index, "uppertol"), "uppertol", where) * f
        lower = _length(_value(record, index, "lowertol"), "lowertol", where) * f
        if not math.isnan(lower) and not math.isnan(upper) and lower > upper:
            raise ParseError(f"lowertol {lower:g} is above uppertol {upper:g}", location=where)
        exceed = _value(record, index, "exceed")
        rows.append(
            {
                "characteristic": label,
                "nominal": nominal,
                "actual": actual,
                "lower": lower,
                "upper": upper,
                "part": _value(record, index, "partnb"),
                "x": _length(_value(record, index, "featureposx"), "featurePosX", where) * f,
                "y": _length(_value(record, index, "featureposy"), "featurePosY", where) * f,
                "z": _length(_value(record, index, "featureposz"), "featurePosZ", where) * f,
                "status": f"exceed {exceed}" if exceed else "",
                "source": f"{name}:{line}",
                **_geometry(_value(record, index, "idsymbol")),
                FEATURE_ID_COLUMN: _value(record, index, "featureid"),
                DATUMS_COLUMN: "|".join(d for d in (_value(record, index, f"datum{c}id") for c in "abc") if d),
            }
        )
    if not rows:
        raise ParseError("no characteristic rows", location=SourceLocation(name))
    return finish_table(rows, name)


def _geometry(symbol: str) -> dict[str, object]:
    """The geometry columns an ``idsymbol`` states (direction of a coordinate, a size)."""
    axis, size = _SYMBOLS.get(symbol.strip().lower(), ("", ""))
    return geometry_cells(axis_vector(axis), size=size)
