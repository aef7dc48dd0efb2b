"""Column-wise (vectorised) reading of a PC-DMIS / NC Gage CSV export.

Same rules as :func:`parsers.pcdmis.text_report.rows_from_raw`, applied to whole
columns so that a 100 000-row export reads in a fraction of a second; the first
offending row of any check is re-checked by the row-wise helpers, so errors carry
the same message and line.  Files whose rows cannot be tied to lines one to one
(a quoted field holding a line break) return None and are read row by row.
"""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pandas as pd

from parsers.geometry import DIRECTION_COLUMNS
from parsers.pcdmis.axes import ANGLE_AXES, NON_LENGTH_AXES
from parsers.rows import (
    SkipLog,
    checked_deviation,
    finish_rows,
    parse_number,
    unit_factor,
    unit_or_none,
    warn_assumed_mm,
)
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.model.measurements import (
    ACTUAL_POSITION_COLUMNS,
    BETWEEN_COLUMN,
    CANONICAL_COLUMNS,
    FEATURE_ID_COLUMN,
)

__all__ = ["STAMP", "heading_of", "read_columns"]

_COLUMNS = {
    "feature": "name",
    "id": "name",
    "axis": "axis",
    "axisletter": "axis",
    "nominal": "nominal",
    "meas": "meas",
    "measured": "meas",
    "+tol": "plus",
    "plus": "plus",
    "-tol": "minus",
    "minus": "minus",
    "dev": "dev",
    "outtol": "outtol",
    "unit": "unit",
}
_LABELS = {"nominal": "NOMINAL", "meas": "MEAS", "plus": "PLUS", "minus": "MINUS", "dev": "DEV", "outtol": "OUTTOL"}
#: NC Gage ``DateTime`` value, ``yyyyMMddhhmmssfff``.
STAMP = re.compile(r"^(\d{4})(\d{2})(\d{2})(\d{2})(\d{2})(\d{2})\d*$")


def heading_of(record: list[str]) -> dict[str, int] | None:
    """Column key → index when ``record`` is a FEATURE/AXIS/NOMINAL/MEAS heading, else None."""
    keys: dict[str, int] = {}
    for i, cell in enumerate(record):
        key = _COLUMNS.get(cell.strip().lower())
        if key and key not in keys:
            keys[key] = i
    return keys if {"name", "axis", "nominal", "meas"} <= keys.keys() else None


def _numbers(cells: np.ndarray, lines: np.ndarray, name: str, key: str) -> np.ndarray:
    """Stripped text column as floats (NaN where empty); the first non-number raises with its line."""
    if cells.dtype.kind == "f":
        bad = np.isinf(cells)
        if bad.any():
            i = int(np.argmax(bad))
            raise ParseError(
                f"{_LABELS[key]}: expected a finite number, found {cells[i]!r}",
                location=SourceLocation(name, line=int(lines[i])),
            )
        return cells
    values = np.full(len(cells), np.nan)
    filled = cells != ""
    try:
        values[filled] = cells[filled].astype(float)
        bad = filled & ~np.isfinite(values)
    except ValueError:
        bad = filled & np.isnan(pd.to_numeric(pd.Series(cells), errors="coerce").to_numpy(float))
    if bad.any():
        i = int(np.argmax(bad))
        where = SourceLocation(name, line=int(lines[i]))
        parse_number(str(cells[i]), where, _LABELS[key])
        raise ParseError(f"{_LABELS[key]}: expected a finite number, found {cells[i]!r}", location=where)
    return values


def read_columns(text: str, name: str, default_unit: str | None) -> pd.DataFrame | None:
    """Read the export column-wise, or return None when rows and lines do not correspond."""
    lines = text.split("\n")
    meta: dict[str, str] = {}
    heading = None
    heading_at = 0  # index of the heading line
    for number, line in enumerate(lines[:50]):
        try:
            record = next(csv.reader([line]), [])
        except csv.Error:
            return None
        heading = heading_of(record)
        if heading is not None:
            heading_at = number
            break
        if len(record) >= 2:
            meta[record[0].strip().lower()] = record[1].strip()
    if heading is None:
        return None
    body = "\n".join(lines[heading_at + 1 :])
    line_numbers = np.array(
        [heading_at + 2 + i for i, row in enumerate(lines[heading_at + 1 :]) if row.strip(' ,\r\t"')]
    )
    try:
        # Numbers are converted by the C parser; text columns stay text. Only "" is missing.
        text_columns = {i: object for key, i in heading.items() if key in ("name", "axis", "unit")}
        table = pd.read_csv(
            io.StringIO(body),
            header=None,
            dtype=text_columns,
            keep_default_na=False,
            na_values=[""],
            skip_blank_lines=True,
            skipinitialspace=True,
            engine="c",
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError, OverflowError):
        return None
    if len(table):
        table = table[~(table.isna() | (table == "")).all(axis=1)]
    if len(table) != len(line_numbers) or len(table) == 0 or table.shape[1] <= max(heading.values()):
        return None
    cells = {}
    for key, i in heading.items():
        column = table.iloc[:, i]
        if key in ("name", "axis", "unit") or column.dtype.kind not in "fiu":
            cells[key] = np.char.strip(column.fillna("").to_numpy(dtype=str))
        else:
            cells[key] = column.to_numpy(dtype=float)
    other = np.isin(np.char.upper(cells["axis"]), list(ANGLE_AXES | NON_LENGTH_AXES))
    skipped = SkipLog(name)
    for line in line_numbers[other]:
        skipped.add("angle or non-length characteristic(s)", int(line))
    keep = ~other
    cells = {k: v[keep] for k, v in cells.items()}
    lines_kept = line_numbers[keep]
    if "unit" in cells:
        known = {str(text): unit_or_none(str(text)) for text in np.unique(cells["unit"]) if text}
        for text, unit in known.items():
            if unit is None:
                i = int(np.argmax(cells["unit"] == text))
                raise ParseError(f"unknown unit {text!r}", location=SourceLocation(name, line=int(lines_kept[i])))
        units = np.array([known.get(str(t)) or default_unit or "" for t in cells["unit"]], dtype=object)
    else:
        units = np.full(len(lines_kept), default_unit or "", dtype=object)
    factors = {u: unit_factor(u) if u else 1.0 for u in set(units.tolist())}
    factor = np.array([factors[u] for u in units], dtype=float)
    num = {
        k: _numbers(cells[k], lines_kept, name, k) if k in cells else np.full(len(lines_kept), np.nan)
        for k in ("nominal", "meas", "plus", "minus", "dev", "outtol")
    }
    signed = bool((num["minus"] < 0).any())
    usable = ~(np.isnan(num["nominal"]) | np.isnan(num["meas"]))
    for line in lines_kept[~usable]:
        skipped.add("row(s) without nominal or measured value", int(line))
    nominal, actual = num["nominal"] * factor, num["meas"] * factor
    deviation = actual - nominal
    stated = num["dev"] * factor
    wrong = usable & ~np.isnan(stated) & (np.abs(stated - deviation) > 0.0011)
    if wrong.any():
        i = int(np.argmax(wrong))
        checked_deviation(nominal[i], actual[i], stated[i], SourceLocation(name, line=int(lines_kept[i])))
    upper = num["plus"] * factor
    lower = (num["minus"] if signed else -np.abs(num["minus"])) * factor + 0.0
    above = usable & (lower > upper)
    if above.any():
        i = int(np.argmax(above))
        raise ParseError(
            f"-TOL {num['minus'][i]:g} lies above +TOL {num['plus'][i]:g}",
            location=SourceLocation(name, line=int(lines_kept[i])),
        )
    with np.errstate(invalid="ignore"):
        expected = np.where(np.isnan(upper), 0.0, np.maximum(deviation - upper, 0.0))
        expected = np.where(~np.isnan(lower) & (deviation < lower), lower - deviation, expected)
        outtol = num["outtol"]
        mismatch = np.abs(np.abs(outtol * factor) - expected) > np.maximum(0.0011, 0.00011 * factor)
        off = usable & ~np.isnan(outtol) & mismatch
    if off.any():
        i = int(np.argmax(off))
        raise ParseError(
            f"OUTTOL {outtol[i]:g} contradicts the deviation and tolerances "
            f"(expected {expected[i] / factor[i]:g}); is -TOL signed?",
            location=SourceLocation(name, line=int(lines_kept[i])),
        )
    if not usable.any():
        return finish_rows([], name, skipped, what="PC-DMIS CSV")
    stamp = STAMP.match(meta.get("datetime", ""))
    names, axes = cells["name"][usable].astype(object), cells["axis"][usable].astype(object)
    n = int(usable.sum())
    frame = pd.DataFrame(
        {
            "characteristic": [f"{a}.{b}" if b else a for a, b in zip(names, axes, strict=True)],
            "nominal": nominal[usable],
            "actual": actual[usable],
            "deviation": deviation[usable],
            "lower": lower[usable],
            "upper": upper[usable],
            "unit": "mm",
            "part": meta.get("serial number") or f"{meta.get('part name', 'part')}#1",
            "report": name.replace("\\", "/").rsplit("/", 1)[-1],
            "timestamp": "{}-{}-{}T{}:{}:{}".format(*stamp.groups()) if stamp else "",
            "station": "",
            "x": np.full(n, np.nan),
            "y": np.full(n, np.nan),
            "z": np.full(n, np.nan),
            "status": np.where(np.isnan(outtol[usable]), "", np.where(outtol[usable] != 0, "out", "ok")),
            "source": [f"{name}:{line}" for line in lines_kept[usable]],
        },
        columns=list(CANONICAL_COLUMNS),
    )
    letters = np.char.upper(np.char.strip(axes.astype(str)))
    along = np.isin(letters, ["X", "Y", "Z"])
    for direction, letter in zip(DIRECTION_COLUMNS, "XYZ", strict=True):  # as text_report.geometry_of, by column
        frame[direction] = np.where(letters == letter, 1.0, np.where(along, 0.0, np.nan))
    frame["feature"] = ""
    frame["size"] = np.where(letters == "D", "diameter", np.where(letters == "R", "radius", "")).astype(object)
    frame["side"] = ""
    # as text_report: the X, Y and Z rows of a feature are its nominal and measured location (the
    # later row of a name measured twice wins); every row of the feature carries it
    keys = names.astype(str)
    frame[FEATURE_ID_COLUMN] = keys.astype(object)
    frame[BETWEEN_COLUMN] = ""  # an export names one feature a row
    for col, measured, letter in zip(("x", "y", "z"), ACTUAL_POSITION_COLUMNS, "XYZ", strict=True):
        rows = letters == letter
        nominal_of = dict(zip(keys[rows], frame["nominal"].to_numpy()[rows], strict=True))
        actual_of = dict(zip(keys[rows], frame["actual"].to_numpy()[rows], strict=True))
        frame[col] = np.array([nominal_of.get(k, np.nan) for k in keys], dtype=float)
        frame[measured] = np.array([actual_of.get(k, np.nan) for k in keys], dtype=float)
    skipped.warn()
    unstated = units[usable] == ""
    if unstated.any():
        warn_assumed_mm(name, int(lines_kept[usable][int(np.argmax(unstated))]))
    return frame
