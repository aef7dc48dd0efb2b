"""Reader for the canonical measurement CSV (``../shared/spec/measurements.md``).

It is the table every other reader produces, so this reader is also the strictest:
a value that is not a number, a missing required column or a deviation that
contradicts ``actual − nominal`` is refused with the file and line.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from parsers.numbers import MAX_NUMBER_CHARS, number_pattern, try_number
from parsers.source import Source, csv_records, decode, point_number, read_bytes
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS, length_factor
from setupfix.model.measurements import (
    BETWEEN_COLUMN,
    CANONICAL_COLUMNS,
    DATUMS_COLUMN,
    FEATURE_ID_COLUMN,
    LENGTH_COLUMNS,
    OPTIONAL_LENGTH_COLUMNS,
    UNCERTAINTY_COLUMN,
)

__all__ = ["read_canonical", "sniff_canonical", "finish_table", "DEVIATION_TOLERANCE_MM"]

#: Largest accepted difference between a stated deviation and actual − nominal [mm].
#: Reports round each value to their display resolution (0.001 mm at worst in the
#: samples), so two roundings can differ by one display step; more is a contradiction.
DEVIATION_TOLERANCE_MM = 0.0011


def _unescaped(cell: str) -> str:
    """A text cell as written before :func:`setupfix.outputs.writers.escape_formulas` prefixed it."""
    return cell[1:] if cell[:1] == "'" and cell[1:2] in ("=", "+", "-", "@", "\t", "\r") else cell


#: Text columns whose control characters are masked as ``?`` (as ``setupfix model check`` shows
#: them) so that a name cannot drive the operator's terminal.
TEXT_COLUMNS = ("characteristic", "part", "station", "report", "status", "timestamp")
#: The optional text columns a report's names fill (masked as the others when present).
OPTIONAL_TEXT_COLUMNS = (FEATURE_ID_COLUMN, BETWEEN_COLUMN, DATUMS_COLUMN)
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def escape_controls(text: str) -> str:
    """``text`` with each control character (an escape sequence's ESC, a bell, …) replaced by ``?``."""
    return _CONTROL.sub("?", text)


def sniff_canonical(head: str) -> bool:
    """True if the first line of ``head`` is a canonical CSV header. Never raises."""
    try:
        first = head.lstrip("\ufeff").splitlines()[0] if head else ""
        cols = {c.strip().lower() for c in next(csv.reader([first]))}
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False
    return {"characteristic", "nominal"} <= cols and bool(cols & {"actual", "deviation"})


def finish_table(rows: list[dict[str, object]] | dict[str, object], path: str) -> pd.DataFrame:
    """Build a canonical DataFrame from row dicts (or a dict of columns) already in mm.

    Fills ``deviation``/``actual`` from each other, defaults ``unit`` to mm,
    ``report`` to the file name, masks control characters in the text columns,
    refuses lengths beyond :data:`MAX_LENGTH_MM` (the optional length columns too, where given:
    :data:`~setupfix.model.measurements.OPTIONAL_LENGTH_COLUMNS`), and orders the canonical columns first.

    The work is done on plain columns (lists and arrays) and the DataFrame is built
    once at the end: per-column pandas operations cost ~0.2 ms each, which made this
    function the largest cost of reading a 28-row report (issue 15).

    Raises
    ------
    ParseError
        For a length beyond :data:`MAX_LENGTH_MM`, at the row's ``source``.
    """
    columns = _columns(rows)
    n = len(next(iter(columns.values()))) if columns else 0
    for col in CANONICAL_COLUMNS:
        if col not in columns:
            columns[col] = np.full(n, math.nan) if col in LENGTH_COLUMNS else [""] * n
    columns["unit"] = ["mm"] * n
    lengths = {col: _floats(columns[col]) for col in (*LENGTH_COLUMNS, *OPTIONAL_LENGTH_COLUMNS) if col in columns}
    difference = clean_deviation(lengths["actual"], lengths["nominal"])
    lengths["deviation"] = np.where(np.isnan(difference), lengths["deviation"], difference)
    columns.update(lengths)
    for col in TEXT_COLUMNS:
        columns[col] = _masked(columns[col])
    for col in OPTIONAL_TEXT_COLUMNS:
        if col in columns:
            columns[col] = _masked(columns[col])
    _check_magnitudes(lengths, columns["source"], path)
    name = Path(path).name
    columns["report"] = [name if _blank(v) else v for v in _values(columns["report"])]
    order = list(CANONICAL_COLUMNS) + [c for c in columns if c not in CANONICAL_COLUMNS]
    return pd.DataFrame({c: columns[c] for c in order}, index=pd.RangeIndex(n))


#: A column as :func:`finish_table` handles it: a list, an array or (rows of unequal keys) a Series.
_Column = list[object] | np.ndarray | pd.Series


def _columns(rows: list[dict[str, object]] | dict[str, object]) -> dict[str, _Column]:
    """The columns of ``rows`` as ``pd.DataFrame(rows)`` would hold them, without building it.

    Rows with the same keys (every reader's case) and dicts of equal-length lists or
    arrays are taken as they are; anything else goes through :class:`pandas.DataFrame`
    (missing cells NaN, scalars broadcast), so the result never differs from it.
    """
    if isinstance(rows, dict):
        values = list(rows.values())
        if (
            values
            and all(isinstance(v, (list, np.ndarray)) and np.ndim(v) == 1 for v in values)
            and len({len(v) for v in values}) == 1  # type: ignore[arg-type]  # lists or arrays: tested
        ):
            return dict(rows)  # type: ignore[arg-type]  # columns of equal length: tested
    elif rows and all(type(r) is dict for r in rows):
        keys = list(dict.fromkeys(k for r in rows for k in r))
        if all(len(r) == len(keys) for r in rows):
            return {k: [r[k] for r in rows] for k in keys}
    frame = pd.DataFrame(rows)
    return {str(c): frame[c] for c in frame.columns}


def _values(column: _Column) -> list[object]:
    return column if isinstance(column, list) else column.tolist()


def _floats(column: _Column) -> np.ndarray:
    """A length column as float64, non-numbers NaN (``pd.to_numeric(errors="coerce")``, fast for floats)."""
    if isinstance(column, np.ndarray) and column.dtype.kind in "fiu":
        return column.astype(float)
    if isinstance(column, list) and all(type(v) is float for v in column):
        return np.array(column, dtype=float)
    series = column if isinstance(column, pd.Series) else pd.Series(column)
    return pd.to_numeric(series, errors="coerce").astype(float).to_numpy()


def _masked(column: _Column) -> _Column:
    """A text column with control characters masked (:func:`escape_controls`); unchanged when it has none."""
    values = _values(column)
    try:
        joined = "".join(values)  # type: ignore[arg-type]  # a text column; TypeError below if not
    except TypeError:  # not all text (NaN, numbers): look at the text only
        joined = "".join(v for v in values if isinstance(v, str))
    if _CONTROL.search(joined) is None:
        return column
    return [escape_controls(v) if isinstance(v, str) else v for v in values]


def _blank(value: object) -> bool:
    """An empty ``report`` cell: None, NaN/NA or the empty string."""
    if isinstance(value, str):
        return value == ""
    cell: Any = value
    return cell is None or (np.ndim(cell) == 0 and bool(pd.isna(cell)))


#: Largest length a report row may hold [mm]: 10 km.  A larger value (``actual = 1e308``,
#: ``1e307`` inch) is damage; refusing it here keeps inf/overflow out of every later sum.
MAX_LENGTH_MM = 1e7


#: Relative size of the binary noise in ``actual − nominal``: each operand is off by up to half an
#: ulp, so the difference by up to one ulp of the larger (2.2e-16 of its size); digits below that
#: are noise, nothing a report wrote (a double cannot hold them).
_NOISE = 2.2e-16


def clean_deviation(actual: np.ndarray, nominal: np.ndarray) -> np.ndarray:
    """``actual − nominal`` without the binary noise of the subtraction.

    The difference is rounded at the decimal place of its noise (one ulp of the larger
    operand): ``22.7205 − 22.7206`` gives ``-0.0001``, not ``-0.000100000000003``;
    every digit either operand carries is kept.

    Parameters
    ----------
    actual, nominal : ndarray, shape (n,)
        In mm; NaN where absent (the result is NaN there).
    """
    with np.errstate(all="ignore"):
        difference = actual - nominal
        scale = np.maximum(np.abs(actual), np.abs(nominal)) * _NOISE
        decimals = np.clip(np.floor(-np.log10(np.where(scale > 0, scale, 1e-300))), 0, 15)
        factor = 10.0**decimals
        rounded = np.round(difference * factor) / factor
    out: np.ndarray = np.where(np.isfinite(rounded), rounded, difference)
    return out


def _check_magnitudes(lengths: dict[str, np.ndarray], source: _Column, path: str) -> None:
    """Refuse a row with a length beyond :data:`MAX_LENGTH_MM` (NaN, i.e. absent, is fine)."""
    for col in lengths:
        values = lengths[col]
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(np.abs(values) > MAX_LENGTH_MM)
        if bad.size:
            i = int(bad[0])
            raise ParseError(
                f"{col} {values[i]:g} mm is beyond any measurable length",
                location=_location_of(str(_values(source)[i]), path),
            )


def _location_of(source: str, path: str) -> SourceLocation:
    """The location a row's ``source`` (``file:line``, else the file) names."""
    head, sep, tail = source.rpartition(":")
    if sep and tail.isdigit():
        return SourceLocation(head, line=int(tail))
    return SourceLocation(path)


#: Spellings of the ``reference`` flag that ``setupfix parse`` writes (and shop tables use).
_FLAGS = {"true": True, "1": True, "yes": True, "false": False, "0": False, "no": False, "": False}


def _flag(text: str, where: SourceLocation) -> bool:
    """The reference-only flag of a row: True/False (1/0, yes/no; empty is False)."""
    try:
        return _FLAGS[text.strip().lower()]
    except KeyError:
        raise ParseError(f"column 'reference': expected True or False, found {text!r}", location=where) from None


def read_canonical(
    path: str | Path | Source, *, text: str | None = None, unit: str | None = None, encoding: str | None = None
) -> pd.DataFrame:
    """Read a canonical measurement CSV into the canonical table (lengths in mm).

    Parameters
    ----------
    path : str or Path
        The file (also used in messages and as default ``report``).
    text : str, optional
        Already decoded content; read from ``path`` when omitted.
    unit : {"mm", "inch"}, optional
        Unit of rows that have no ``unit`` value (default mm).
    encoding : str, optional
        Read the file in this encoding instead of the UTF-8 the spec prescribes.

    Raises
    ------
    ParseError
        On a missing required column, a non-numeric length, an unknown unit or a
        deviation that contradicts actual − nominal; names file and line.
    """
    name = str(path)
    if text is None:
        data = read_bytes(path)
        if encoding:
            text = decode(data, name, encoding)
        else:
            try:
                text = data.decode("utf-8-sig")
            except UnicodeDecodeError as exc:
                where = SourceLocation(name, line=data[: exc.start].count(b"\n") + 1)
                raise ParseError("not UTF-8 text", location=where, hint="give its encoding with --encoding") from None
    body = text.lstrip("\ufeff")
    records = csv_records(body, name)
    try:
        header = [h.strip().lower() for h in next(records)[1]]
    except StopIteration:
        raise ParseError("empty file", location=SourceLocation(name, line=1)) from None
    missing = [c for c in ("characteristic", "nominal") if c not in header]
    if not ("actual" in header or "deviation" in header):
        missing.append("actual (or deviation)")
    if missing:
        raise ParseError(f"missing required column(s): {', '.join(missing)}", location=SourceLocation(name, line=1))
    columns = _plain_columns(body, header, name, unit) if FAST_PATH else None
    if columns is not None:
        return finish_table(columns, name)
    rows: list[dict[str, object]] = []
    width = len(header)
    # every row holds every header key
    lengths_here = [c for c in (*LENGTH_COLUMNS, *OPTIONAL_LENGTH_COLUMNS) if c in header]
    factors: dict[str, float] = {}
    for line_num, record in records:
        if not any(cell.strip() for cell in record):
            continue
        if len(record) > width:
            raise ParseError(f"{len(record)} fields, header has {width}", location=SourceLocation(name, line=line_num))
        # A short row: the columns past its end are filled below.
        row: dict[str, object] = dict(zip(header, [_unescaped(c.strip()) for c in record], strict=False))
        for col in header[len(record) :]:
            row[col] = ""
        if not row["characteristic"]:
            raise ParseError("empty characteristic name", location=SourceLocation(name, line=line_num))
        row_unit = str(row.get("unit") or unit or "mm")
        factor = factors.get(row_unit)
        if factor is None:
            if row_unit.strip().lower() not in LENGTH_UNITS:
                raise ParseError(
                    f"unknown unit {row_unit!r} (expected mm or inch)", location=SourceLocation(name, line=line_num)
                )
            factor = factors[row_unit] = length_factor(row_unit, "mm")
        for col in lengths_here:
            cell = str(row[col])
            # The grammar's fast path; anything it does not read (empty, damaged) goes through
            # point_number, which gives NaN for empty text or the error naming file and line.
            value = try_number(cell)
            if value is None:
                value = point_number(cell, SourceLocation(name, line=line_num), f"column {col!r}: ")
            row[col] = value * factor
        nominal, actual = float(row["nominal"]), float(row.get("actual", math.nan))  # type: ignore[arg-type]  # numbers by now
        stated = float(row.get("deviation", math.nan))  # type: ignore[arg-type]  # numbers by now
        if math.isnan(nominal):
            raise ParseError("empty nominal value", location=SourceLocation(name, line=line_num))
        if math.isnan(actual) and math.isnan(stated):
            raise ParseError("neither actual nor deviation is given", location=SourceLocation(name, line=line_num))
        if math.isnan(actual):
            actual = nominal + stated
        elif not math.isnan(stated) and abs(stated - (actual - nominal)) > DEVIATION_TOLERANCE_MM:
            raise ParseError(
                f"deviation {stated:g} mm contradicts actual - nominal = {actual - nominal:g} mm",
                location=SourceLocation(name, line=line_num),
            )
        row["actual"], row["deviation"] = actual, actual - nominal
        if float(row.get(UNCERTAINTY_COLUMN, 0.0)) < 0:  # type: ignore[arg-type]  # numbers by now
            raise ParseError(
                f"uncertainty {row[UNCERTAINTY_COLUMN]:g} is negative (an expanded uncertainty U is a size)",
                location=SourceLocation(name, line=line_num),
            )
        lo, up = float(row.get("lower", math.nan)), float(row.get("upper", math.nan))  # type: ignore[arg-type]  # numbers by now
        if not math.isnan(lo) and not math.isnan(up) and lo >= up:
            raise ParseError(
                f"lower limit {lo:g} is not below upper limit {up:g}", location=SourceLocation(name, line=line_num)
            )
        if "reference" in row:
            row["reference"] = _flag(str(row["reference"]), SourceLocation(name, line=line_num))
        row["source"] = f"{name}:{line_num}"
        rows.append(row)
    if not rows:
        raise ParseError("no measurement rows", location=SourceLocation(name))
    return finish_table(rows, name)


#: Whether :func:`read_canonical` tries :func:`_plain_columns` first (tests compare both paths).
FAST_PATH = True

#: Longest line the fast path takes: the csv module refuses a field over 131,072 characters.
_MAX_PLAIN_LINE = 131072

_NUMBER = number_pattern(".")


def _plain_columns(body: str, header: list[str], name: str, unit: str | None) -> dict[str, object] | None:
    """The columns the row loop of :func:`read_canonical` would build, column by column; or None.

    A plain file (no quote, no NUL, no lone carriage return, no huge line, unique
    headers, every row complete) whose every cell passes every check of the row loop
    is read here a column at a time (several times faster on large files).  Anything
    else — any cell the loop would refuse or treat specially — gives None, and the
    loop reads the file and names the first offending line.  Same values, same checks,
    same order of keys (tested against the loop on every sample and on fuzzed files).
    """
    if '"' in body or "\x00" in body or body.count("\r") != body.count("\r\n") or len(set(header)) != len(header):
        return None
    lines = body.replace("\r\n", "\n").split("\n")
    if max(map(len, lines)) >= _MAX_PLAIN_LINE:
        return None
    width = len(header)
    # A line is blank for the loop when every field is white space: exactly when the line
    # without its commas is.
    kept = [(i, line) for i, line in enumerate(lines[1:], start=2) if line.replace(",", "").strip()]
    if not kept:
        return None
    records = [line.split(",") for _, line in kept]
    if any(len(r) != width for r in records):
        return None
    unescape = "'" in body
    cells: dict[str, list[str]] = {}
    for col, values in zip(header, zip(*records, strict=True), strict=True):
        cells[col] = [_unescaped(v.strip()) for v in values] if unescape else [v.strip() for v in values]
    if not all(cells["characteristic"]):
        return None
    n = len(records)
    spellings = cells["unit"] if "unit" in cells else [""] * n
    factors = {}
    for spelling in set(spellings):
        row_unit = str(spelling or unit or "mm")
        if row_unit.strip().lower() not in LENGTH_UNITS:
            return None
        factors[spelling] = length_factor(row_unit, "mm")
    factor = np.array([factors[s] for s in spellings]) if len(factors) > 1 else next(iter(factors.values()))
    out: dict[str, object] = {}
    numbers: dict[str, np.ndarray] = {}
    lengths = {*LENGTH_COLUMNS, *OPTIONAL_LENGTH_COLUMNS}
    for col in header:
        if col not in lengths:
            out[col] = cells[col]
            continue
        text = cells[col]
        if max(map(len, text)) > MAX_NUMBER_CHARS or not all(map(_NUMBER.fullmatch, filter(None, text))):
            return None
        raw = np.array([float(v) if v else math.nan for v in text])  # NaN exactly where empty
        with np.errstate(over="ignore", invalid="ignore"):
            scaled = raw * factor
        if (~np.isfinite(scaled) & ~np.isnan(raw)).any():
            return None  # beyond the range of a length (the loop names it)
        numbers[col] = out[col] = scaled
    nan = np.full(n, math.nan)
    nominal, actual, stated = numbers["nominal"], numbers.get("actual", nan), numbers.get("deviation", nan)
    if np.isnan(nominal).any() or (np.isnan(actual) & np.isnan(stated)).any():
        return None
    with np.errstate(invalid="ignore"):
        disagree = np.abs(stated - (actual - nominal)) > DEVIATION_TOLERANCE_MM
        if (~np.isnan(actual) & ~np.isnan(stated) & disagree).any():
            return None
        actual = np.where(np.isnan(actual), nominal + stated, actual)
        lo, up = numbers.get("lower", nan), numbers.get("upper", nan)
        if (lo >= up).any():  # NaN compares False: a missing limit is fine
            return None
        if (numbers.get(UNCERTAINTY_COLUMN, nan) < 0).any():
            return None
    out["actual"], out["deviation"] = actual, actual - nominal
    if "reference" in out:
        flags = [_FLAGS.get(v.strip().lower()) for v in cells["reference"]]
        if any(f is None for f in flags):
            return None
        out["reference"] = flags
    out["source"] = [f"{name}:{line}" for line, _ in kept]
    return out
