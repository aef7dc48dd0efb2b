"""PC-DMIS / Hexagon NC Gage CSV export: one row per feature axis.

The documented Hexagon layout (NC Gage, appendix *CSV format*) has a few key/value
lines (``DateTime,"yyyyMMddhhmmssfff"``, ``Part Name,…``) and then the heading
``FEATURE, AXIS, NOMINAL, MEAS, +TOL, -TOL, DEV, OUTTOL`` with every field quoted and
numbers like ``".1000"``.  Columns are found by heading name, so the same reader takes
the ``ID,…,AxisLetter,Unit,Nominal,Plus,Minus,Measured`` export of PC-DMIS scripts.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from operator import itemgetter
from pathlib import Path

import pandas as pd

from parsers.pcdmis.axes import ANGLE_AXES, NON_LENGTH_AXES
from parsers.pcdmis.columns import STAMP, heading_of, read_columns
from parsers.pcdmis.text_report import RawRecord, rows_from_raw
from parsers.rows import SkipLog, unit_or_none
from parsers.source import read_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.model.measurements import FEATURE_ID_COLUMN

__all__ = ["read_pcdmis_csv", "sniff_pcdmis_csv"]


def sniff_pcdmis_csv(text: str) -> bool:
    """True if one of the first lines is a FEATURE/AXIS/NOMINAL/MEAS heading. Never raises."""
    try:
        for record in csv.reader(io.StringIO("\n".join(text.lstrip("\ufeff").splitlines()[:12]))):
            if heading_of(record):
                return True
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False
    return False


def read_pcdmis_csv(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a PC-DMIS / NC Gage CSV export into the canonical table.

    Parameters
    ----------
    path : str or Path
    unit : {"mm", "inch"}, optional
        Unit when the file has no ``Unit`` column (default mm, with a warning).
    encoding : str, optional

    Raises
    ------
    ParseError
        If no heading is found, a value is not a number, or a deviation contradicts.
    """
    name = str(path)
    default_unit = unit_or_none(unit) if unit else None
    if unit and default_unit is None:
        raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
    text = read_text(path, encoding).lstrip("\ufeff")
    fast = read_columns(text, name, default_unit)
    if fast is not None:
        return fast
    return read_rows(text, name, default_unit)


def read_rows(text: str, name: str, default_unit: str | None) -> pd.DataFrame:
    """Row-by-row reading (any CSV, also with quoted line breaks); see :func:`read_pcdmis_csv`."""
    skipped = SkipLog(name)
    meta: dict[str, str] = {}
    cols: dict[str, int] | None = None
    raws: list[RawRecord] = []
    part: str | None = None
    getter: Callable[[list[str]], tuple[str, ...]] | None = None
    keys: list[str] = []
    width = 0
    extra: dict[str, str] = {}
    reader = csv.reader(io.StringIO(text))
    try:
        for record in reader:
            where = SourceLocation(name, line=reader.line_num)
            if cols is None:
                cols = heading_of(record)
                if cols is None and len(record) >= 2:
                    meta[record[0].strip().lower()] = record[1].strip()
                continue
            if not "".join(record).strip():
                continue
            if getter is None:
                keys, getter, width = list(cols), itemgetter(*cols.values()), max(cols.values()) + 1
            if len(record) >= width:
                cells = dict(zip(keys, map(str.strip, getter(record)), strict=True))
            else:
                cells = {k: record[i].strip() for k, i in cols.items() if i < len(record)}
            axis = cells.get("axis", "")
            if axis.upper() in ANGLE_AXES or axis.upper() in NON_LENGTH_AXES:
                skipped.add("angle or non-length characteristic(s)", reader.line_num)
                continue
            row_unit = default_unit
            if cells.get("unit"):
                row_unit = unit_or_none(cells["unit"])
                if row_unit is None:
                    raise ParseError(f"unknown unit {cells['unit']!r}", location=where)
            if part is None:
                part = meta.get("serial number") or f"{meta.get('part name', 'part')}#1"
                stamp = STAMP.match(meta.get("datetime", ""))
                extra = {"timestamp": "{}-{}-{}T{}:{}:{}".format(*stamp.groups())} if stamp else {}
            name_ = cells.get("name", "")
            own = {**extra, FEATURE_ID_COLUMN: name_} if name_ else extra
            raws.append(RawRecord(name_, axis, cells, row_unit or "", part, where, own))
    except csv.Error as exc:
        raise ParseError(f"malformed CSV: {exc}", location=SourceLocation(name, line=reader.line_num)) from None
    if cols is None:
        raise ParseError("no FEATURE, AXIS, NOMINAL, MEAS heading found", location=SourceLocation(name))
    return rows_from_raw(raws, name, skipped, what="PC-DMIS CSV")
