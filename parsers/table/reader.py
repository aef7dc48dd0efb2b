"""Shop tables (CSV and Excel ``.xlsx``) → the canonical table, through a column mapping.

The grid is read by pandas (CSV, with the delimiter sniffed by :class:`csv.Sniffer`)
or python-calamine (Excel; openpyxl, read-only with cached formula values, where
calamine is absent), then converted column-wise with pandas, so a table of 100 000
rows is read in about a second.  Every row
keeps its place (``file:line`` or ``file#Sheet!row``) as provenance; a bad cell is
reported with its line or cell.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from parsers.canonical import DEVIATION_TOLERANCE_MM, finish_table
from parsers.numbers import MAX_NUMBER_CHARS, number_pattern
from parsers.source import decode, read_bytes
from parsers.table.limits import check_workbook
from parsers.table.mapping import guess_columns, parse_columns
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS, length_factor
from setupfix.model.measurements import OPTIONAL_LENGTH_COLUMNS, UNCERTAINTY_COLUMN

__all__ = ["read_table", "sniff_table", "load_grid"]

_NUMERIC = (
    "nominal",
    "actual",
    "deviation",
    "lower",
    "upper",
    "lsl",
    "usl",
    "tolerance",
    "x",
    "y",
    "z",
    *OPTIONAL_LENGTH_COLUMNS,
)
_ZIP = b"PK\x03\x04"
#: Rows of a worksheet (lines of a text table) searched for the header row.
_HEADER_SEARCH = 30


def sniff_table(head: bytes, text: str) -> bool:
    """True for an Excel workbook, or a delimited text whose header names a nominal,
    an actual and a characteristic column by a common spelling. Never raises."""
    try:
        if head.startswith(_ZIP):
            return b"xl/" in head or b"[Content_Types].xml" in head
        first = text.lstrip("\ufeff").split("\n", 1)[0]
        if not first.strip():
            return False
        delim = max(",;\t", key=first.count)
        keys = guess_columns(next(csv.reader([first], delimiter=delim)), {})
        return {"characteristic", "nominal"} <= keys.keys() and bool(keys.keys() & {"actual", "deviation"})
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


def _delimiter(text: str) -> str:
    sample = "\n".join(text[:8192].splitlines()[:20])
    try:
        return csv.Sniffer().sniff(sample, delimiters=",;\t|").delimiter
    except csv.Error:
        first = sample.split("\n", 1)[0]
        return max(",;\t|", key=first.count)


def load_grid(
    path: str | Path, *, encoding: str | None = None, sheet: str | None = None, mapping: Mapping[str, str] | None = None
) -> tuple[pd.DataFrame, list[str]]:
    """Read a table's cells as text/number objects with its header.

    Returns
    -------
    (frame, sources)
        ``frame`` with the header row as columns (all object dtype, empty rows dropped)
        and ``sources`` giving each row's provenance.

    Raises
    ------
    ParseError
        If the file is neither a workbook nor delimited text, or has no header row.
    """
    name = str(path)
    data = read_bytes(path)
    if data.startswith(_ZIP):
        return _load_excel(data, name, sheet, mapping or {})
    text = decode(data, name, encoding).lstrip("\ufeff")
    if not text.strip():
        raise ParseError("empty file", location=SourceLocation(name, line=1))
    start, delimiter = _header_line(text, mapping or {})
    try:
        frame = pd.read_csv(
            io.StringIO(text),
            sep=delimiter,
            dtype=str,
            keep_default_na=False,
            skip_blank_lines=False,
            skiprows=start,
            engine="c",
        )
    except (pd.errors.ParserError, ValueError) as exc:
        raise ParseError(f"not a delimited table: {str(exc).splitlines()[0]}", location=SourceLocation(name)) from None
    frame = frame.fillna("")
    lines = np.arange(start + 2, start + len(frame) + 2)
    keep = (frame != "").any(axis=1).to_numpy() if len(frame.columns) else np.zeros(len(frame), bool)
    frame = frame[keep].reset_index(drop=True)
    return frame, [f"{name}:{n}" for n in lines[keep]]


def _header_line(text: str, mapping: Mapping[str, str]) -> tuple[int, str]:
    """(0-based line, delimiter) of the header: exports often open with a title block, so
    the first of the top lines that names the mapped (or recognisable) columns, else
    line 0 with the sniffed delimiter."""
    for number, line in enumerate(text.splitlines()[:_HEADER_SEARCH]):
        for delimiter in ",;\t|":
            try:
                if delimiter in line and _is_header(next(csv.reader([line], delimiter=delimiter)), mapping):
                    return number, delimiter
            except csv.Error:  # a NUL byte or the like: not a header line
                continue
    return 0, _delimiter(text)


def _is_header(cells: Sequence[object], mapping: Mapping[str, str]) -> bool:
    names = ["" if c is None else str(c).strip() for c in cells]
    lowered = {n.lower() for n in names}
    if mapping:
        return all(v.strip().lower() in lowered for v in mapping.values())
    return {"characteristic", "nominal"} <= guess_columns(names, {}).keys()


def _excel_rows_calamine(data: bytes, name: str, sheet: str | None) -> tuple[str, list[tuple[int, list[Any]]]]:
    """Sheet title and (row number, cells) of the non-empty rows, read by python-calamine.

    calamine (Rust) reads a worksheet about 9× faster than openpyxl, which builds a
    Python object per cell and stays near 20,000 rows/s (bench/parse_speed.py).
    """
    from python_calamine import CalamineWorkbook

    try:
        book = CalamineWorkbook.from_filelike(io.BytesIO(data))
        names = list(book.sheet_names)
        if sheet is not None and sheet not in names:
            raise ParseError(f"no sheet {sheet!r} (sheets: {', '.join(names)})", location=SourceLocation(name))
        title = sheet if sheet is not None else names[0]
        values = book.get_sheet_by_name(title).to_python(skip_empty_area=False)
    except ParseError:
        raise
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - a Rust panic on a corrupt file is a BaseException
        raise ParseError(f"not a readable Excel workbook: {exc}", location=SourceLocation(name)) from None
    rows = [(r, [None if c == "" else c for c in v]) for r, v in enumerate(values, start=1)]
    return title, [(r, v) for r, v in rows if any(c is not None and str(c).strip() for c in v)]


def _excel_rows_openpyxl(data: bytes, name: str, sheet: str | None) -> tuple[str, list[tuple[int, list[Any]]]]:
    """The same with openpyxl (read-only, cached formula values), where calamine is absent."""
    import zipfile

    import openpyxl
    from openpyxl.utils.exceptions import InvalidFileException

    try:
        book = openpyxl.load_workbook(io.BytesIO(data), read_only=True, data_only=True)
    except (InvalidFileException, zipfile.BadZipFile, KeyError, OSError, ValueError, TypeError) as exc:
        raise ParseError(f"not a readable Excel workbook: {exc}", location=SourceLocation(name)) from None
    try:
        if sheet is not None and sheet not in book.sheetnames:
            raise ParseError(
                f"no sheet {sheet!r} (sheets: {', '.join(book.sheetnames)})", location=SourceLocation(name)
            )
        ws = book[sheet] if sheet is not None else book.worksheets[0]
        rows = [
            (r, list(v))
            for r, v in enumerate(ws.iter_rows(values_only=True), start=1)
            if any(c is not None and str(c).strip() for c in v)
        ]
        return ws.title, rows
    finally:
        book.close()


def _load_excel(
    data: bytes, name: str, sheet: str | None, mapping: Mapping[str, str]
) -> tuple[pd.DataFrame, list[str]]:
    check_workbook(data, name)
    try:
        title, rows = _excel_rows_calamine(data, name, sheet)
    except ImportError:
        title, rows = _excel_rows_openpyxl(data, name, sheet)
    if not rows:
        raise ParseError("empty worksheet", location=SourceLocation(name, element=title))
    # Workbooks often open with a title block: the header is the first of the top rows
    # that names the mapped (or recognisable) columns, else the first row.
    start = next((i for i, (_, v) in enumerate(rows[:_HEADER_SEARCH]) if _is_header(v, mapping)), 0)
    _, header = rows[start]
    width = len(header)
    columns = ["" if h is None else str(h).strip() for h in header]
    body = [[("" if c is None else c) for c in (v + [None] * width)[:width]] for _, v in rows[start + 1 :]]
    frame = pd.DataFrame(body, columns=columns, dtype=object)
    return frame, [f"{name}#{title}!{r}" for r, _ in rows[start + 1 :]]


def _numeric(series: pd.Series, column: str, sources: list[str]) -> np.ndarray:
    """Column to float in the grammar of :mod:`parsers.numbers` (decimal point or comma), vectorised;
    a cell that is not a number (``1_000``, ``nan``, ``inf``, 401 digits) is an error."""
    text = series.astype(str).str.strip()
    spelled = text.str.fullmatch(number_pattern("auto")).to_numpy(dtype=bool) & (text.str.len() <= MAX_NUMBER_CHARS)
    text = text.str.replace(",", ".", regex=False)
    values = pd.to_numeric(text.where(spelled & (text != ""), None), errors="coerce").to_numpy(dtype=float)
    bad = (~spelled & (text != "").to_numpy()) | np.isinf(values)
    if bad.any():
        i = int(np.argmax(bad))
        raise ParseError(f"column {column!r}: expected a number, found {series.iloc[i]!r}", location=_where(sources[i]))
    return values


def _where(source: str) -> SourceLocation:
    path, sep, line = source.rpartition(":")
    if sep and line.isdigit():
        return SourceLocation(path, line=int(line))
    path, _, cell = source.rpartition("#")
    return SourceLocation(path, element=cell)


def read_table(
    path: str | Path,
    *,
    columns: str | Path | Mapping[str, str] | None = None,
    unit: str | None = None,
    encoding: str | None = None,
) -> pd.DataFrame:
    """Read a shop's CSV or Excel table through a column mapping.

    Parameters
    ----------
    path : str or Path
        ``.csv``/``.tsv``/``.txt`` (delimiter sniffed) or ``.xlsx``.
    columns : str, Path or mapping, optional
        See :func:`parsers.table.mapping.parse_columns`; unmapped keys are guessed
        from common header spellings.
    unit : {"mm", "inch"}, optional
        Unit of rows without a mapped ``unit`` value (default mm).
    encoding : str, optional
        Text encoding of a CSV; sniffed when omitted.

    Raises
    ------
    ParseError
        On a missing mapped header, a non-numeric length, an unknown unit or a stated
        deviation that contradicts actual − nominal; names file and line or cell.
    """
    name = str(path)
    given = parse_columns(columns)
    sheet = given.pop("sheet", None)
    grid, sources = load_grid(path, encoding=encoding, sheet=sheet, mapping=given)
    headers = [str(c) for c in grid.columns]
    lookup = {h.strip().lower(): h for h in headers}
    absent = [v for v in given.values() if v.strip().lower() not in lookup]
    if absent:
        raise ParseError(
            f"mapped header(s) not in the table: {', '.join(map(repr, absent))} (headers: {', '.join(headers)})",
            location=SourceLocation(name, line=1),
        )
    mapping = {k: lookup[v.strip().lower()] for k, v in guess_columns(headers, given).items()}
    missing = [k for k in ("characteristic", "nominal") if k not in mapping]
    if "actual" not in mapping and "deviation" not in mapping:
        missing.append("actual (or deviation)")
    if missing:
        raise ParseError(
            f"no column for {', '.join(missing)} (headers: {', '.join(headers)})",
            location=SourceLocation(name, line=1),
            hint="map them with --columns KEY=HEADER,...",
        )
    if grid.empty:
        raise ParseError("no measurement rows", location=SourceLocation(name))
    n = len(grid)
    values = {k: _numeric(grid[mapping[k]], k, sources) if k in mapping else np.full(n, np.nan) for k in _NUMERIC}
    factor = _unit_factors(grid[mapping["unit"]] if "unit" in mapping else None, unit, n, sources)
    for k in _NUMERIC:
        values[k] = values[k] * factor
    nominal, actual, stated = values["nominal"], values["actual"], values["deviation"]
    _require(~np.isnan(nominal), "empty nominal value", sources)
    _require(~(np.isnan(actual) & np.isnan(stated)), "neither actual nor deviation is given", sources)
    actual = np.where(np.isnan(actual), nominal + stated, actual)
    deviation = actual - nominal
    _require(
        np.isnan(stated) | (np.abs(stated - deviation) <= DEVIATION_TOLERANCE_MM),
        "stated deviation contradicts actual - nominal",
        sources,
    )
    lower = np.where(np.isnan(values["lower"]), values["lsl"] - nominal, values["lower"])
    upper = np.where(np.isnan(values["upper"]), values["usl"] - nominal, values["upper"])
    tol = np.abs(values["tolerance"])
    lower, upper = np.where(np.isnan(lower), -tol, lower), np.where(np.isnan(upper), tol, upper)
    _require(np.isnan(lower) | np.isnan(upper) | (lower <= upper), "lower limit is above upper limit", sources)
    _require(~(values[UNCERTAINTY_COLUMN] < 0), "negative uncertainty (an expanded uncertainty U is a size)", sources)
    names = grid[mapping["characteristic"]].astype(str).str.strip()
    _require((names != "").to_numpy(), "empty characteristic name", sources)
    out: dict[str, object] = {
        "characteristic": names.to_numpy(),
        "nominal": nominal,
        "actual": actual,
        "deviation": deviation,
        "lower": lower,
        "upper": upper,
        "x": values["x"],
        "y": values["y"],
        "z": values["z"],
        "source": sources,
    }
    for key in OPTIONAL_LENGTH_COLUMNS:
        if key in mapping:
            out[key] = values[key]
    for key in ("part", "report", "timestamp", "station", "status"):
        if key in mapping:
            out[key] = grid[mapping[key]].astype(str).str.strip().to_numpy()
    return finish_table(out, name)


def _require(ok: np.ndarray, message: str, sources: list[str]) -> None:
    if not bool(np.all(ok)):
        raise ParseError(message, location=_where(sources[int(np.argmin(ok))]))


def _unit_factors(column: pd.Series | None, default: str | None, n: int, sources: list[str]) -> np.ndarray:
    base = (default or "mm").strip().lower()
    if base not in LENGTH_UNITS:
        raise ParseError(f"unknown unit {default!r} (expected mm or inch)", location=SourceLocation("--unit"))
    if column is None:
        return np.full(n, length_factor(base, "mm"))
    names = column.astype(str).str.strip().str.lower().replace("", base)
    factors = names.map(lambda u: length_factor(u, "mm") if u in LENGTH_UNITS else math.nan).to_numpy(dtype=float)
    if np.isnan(factors).any():
        i = int(np.argmax(np.isnan(factors)))
        raise ParseError(f"unknown unit {column.iloc[i]!r} (expected mm or inch)", location=_where(sources[i]))
    return factors
