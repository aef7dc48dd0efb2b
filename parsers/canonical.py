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

import numpy as np
import pandas as pd

from parsers._source import Source, csv_records, decode, point_number, read_bytes
from setupfix.errors import ParseError, SourceLocation
from setupfix.model.measurements import CANONICAL_COLUMNS, LENGTH_COLUMNS
from setupfix.units import LENGTH_UNITS, length_factor

__all__ = ["read_canonical", "sniff_canonical", "finish_table", "DEVIATION_TOLERANCE_MM"]

#: Largest accepted difference between a stated deviation and actual − nominal [mm].
#: Reports round each value to their display resolution (0.001 mm at worst in the
#: samples), so two roundings can differ by one display step; more is a contradiction.
DEVIATION_TOLERANCE_MM = 0.0011


def _unescaped(cell: str) -> str:
    """A text cell as written before :func:`setupfix.pipeline.writers.escape_formulas` prefixed it."""
    return cell[1:] if cell[:1] == "'" and cell[1:2] in ("=", "+", "-", "@", "\t", "\r") else cell


#: Text columns whose control characters are masked as ``?`` (as ``setupfix model check`` shows
#: them) so that a name cannot drive the operator's terminal.
TEXT_COLUMNS = ("characteristic", "part", "station", "report", "status", "timestamp")
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
    ``report`` to the file name, and orders the canonical columns first.
    """
    frame = pd.DataFrame(rows)
    for col in CANONICAL_COLUMNS:
        if col not in frame:
            frame[col] = math.nan if col in LENGTH_COLUMNS else ""
    frame["unit"] = "mm"
    _round_lengths(frame)
    for col in TEXT_COLUMNS:
        text = frame[col]
        dirty = text.map(lambda v: isinstance(v, str) and _CONTROL.search(v) is not None)
        if dirty.any():
            frame[col] = text.where(~dirty, text.map(lambda v: escape_controls(v) if isinstance(v, str) else v))
    _check_magnitudes(frame, path)
    frame.loc[frame["report"].isin(["", None]) | frame["report"].isna(), "report"] = Path(path).name
    extra = [c for c in frame.columns if c not in CANONICAL_COLUMNS]
    return frame[list(CANONICAL_COLUMNS) + extra].reset_index(drop=True)


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
        factor = 10.0 ** decimals
        rounded = np.round(difference * factor) / factor
    return np.where(np.isfinite(rounded), rounded, difference)


def _round_lengths(frame: pd.DataFrame) -> None:
    """Set ``deviation = actual − nominal`` (noise-free, :func:`clean_deviation`) where both are known."""
    for col in LENGTH_COLUMNS:
        frame[col] = pd.to_numeric(frame[col], errors="coerce").astype(float)
    difference = clean_deviation(frame["actual"].to_numpy(), frame["nominal"].to_numpy())
    frame["deviation"] = np.where(np.isnan(difference), frame["deviation"].to_numpy(), difference)


def _check_magnitudes(frame: pd.DataFrame, path: str) -> None:
    """Refuse a row with a length beyond :data:`MAX_LENGTH_MM` (NaN, i.e. absent, is fine)."""
    for col in LENGTH_COLUMNS:
        if col not in frame:
            continue
        values = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(np.abs(values) > MAX_LENGTH_MM)
        if bad.size:
            i = int(bad[0])
            source = str(frame["source"].iat[i]) if "source" in frame else ""
            raise ParseError(f"{col} {values[i]:g} mm is beyond any measurable length",
                             location=_location_of(source, path))


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


def read_canonical(path: str | Path | Source, *, text: str | None = None, unit: str | None = None,
                   encoding: str | None = None) -> pd.DataFrame:
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
                raise ParseError("not UTF-8 text", location=SourceLocation(name, line=data[: exc.start].count(b"\n") + 1),
                                 hint="give its encoding with --encoding") from None
    records = csv_records(text.lstrip("\ufeff"), name)
    try:
        header = [h.strip().lower() for h in next(records)[1]]
    except StopIteration:
        raise ParseError("empty file", location=SourceLocation(name, line=1)) from None
    missing = [c for c in ("characteristic", "nominal") if c not in header]
    if not ("actual" in header or "deviation" in header):
        missing.append("actual (or deviation)")
    if missing:
        raise ParseError(f"missing required column(s): {', '.join(missing)}", location=SourceLocation(name, line=1))
    rows: list[dict[str, object]] = []
    for line_num, record in records:
        where = SourceLocation(name, line=line_num)
        if not any(cell.strip() for cell in record):
            continue
        if len(record) > len(header):
            raise ParseError(f"{len(record)} fields, header has {len(header)}", location=where)
        row: dict[str, object] = dict(zip(header, (_unescaped(c.strip()) for c in record)))
        for col in header[len(record):]:
            row[col] = ""
        if not row["characteristic"]:
            raise ParseError("empty characteristic name", location=where)
        row_unit = str(row.get("unit") or unit or "mm")
        if row_unit.strip().lower() not in LENGTH_UNITS:
            raise ParseError(f"unknown unit {row_unit!r} (expected mm or inch)", location=where)
        factor = length_factor(row_unit, "mm")
        for col in LENGTH_COLUMNS:
            if col in row:
                row[col] = point_number(str(row[col]), where, f"column {col!r}: ") * factor
        nominal, actual = float(row["nominal"]), float(row.get("actual", math.nan))  # type: ignore[arg-type]
        stated = float(row.get("deviation", math.nan))  # type: ignore[arg-type]
        if math.isnan(nominal):
            raise ParseError("empty nominal value", location=where)
        if math.isnan(actual) and math.isnan(stated):
            raise ParseError("neither actual nor deviation is given", location=where)
        if math.isnan(actual):
            actual = nominal + stated
        elif not math.isnan(stated) and abs(stated - (actual - nominal)) > DEVIATION_TOLERANCE_MM:
            raise ParseError(
                f"deviation {stated:g} mm contradicts actual - nominal = {actual - nominal:g} mm", location=where
            )
        row["actual"], row["deviation"] = actual, actual - nominal
        lo, up = float(row.get("lower", math.nan)), float(row.get("upper", math.nan))  # type: ignore[arg-type]
        if not math.isnan(lo) and not math.isnan(up) and lo >= up:
            raise ParseError(f"lower limit {lo:g} is not below upper limit {up:g}", location=where)
        if "reference" in row:
            row["reference"] = _flag(str(row["reference"]), where)
        row["source"] = f"{name}:{line_num}"
        rows.append(row)
    if not rows:
        raise ParseError("no measurement rows", location=SourceLocation(name))
    return finish_table(rows, name)
