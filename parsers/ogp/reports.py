"""OGP SmartScope / Measure-X reports: the step report (plain or RTF-wrapped) and the run table.

*Step report* (``OGP_empty_fixture0.txt``): per ``Step:  n  MM …`` a feature with a
size/location table ``Actual Nominal Upper Lower`` and a form table ``Actual
Tolerance Mod ID/OD``.  Numbers are signed and zero padded (``-005.16258``).

*Run table* (``OGP_L123_fixture_sho_multirun.txt``): runs of one routine concatenated,
each opened by ``Routine Name  Run #  Date & Time``, paginated with a repeated
``Machine Serial Number … Page:`` header, rows ``label nominal actual deviation`` in
fixed columns under ``Step n - comment`` groups.

Vendor conventions handled (see :mod:`parsers.rows` for the shared rules):

* zero ``Upper``/``Lower`` (``+00.00000 -00.00000``) mean *no tolerance*, not a zero zone;
* a size/location row whose nominal equals the actual with no tolerance was taught
  from the part (no nominal loaded in the routine): it carries no deviation and is
  skipped, and so is the step's True Position computed against it;
* the stated deviation of a coordinate is ``|actual| − |nominal|`` (run table, line 31:
  Y −113.895 → −113.903 reported +0.009); it is accepted as such, the table holds
  actual − nominal;
* form rows (flatness, sphericity, …) have nominal 0 and the tolerance as upper limit.
"""

from __future__ import annotations

import math
import re
from datetime import datetime
from functools import lru_cache
from pathlib import Path

import pandas as pd

from parsers.ogp.rtf import is_rtf, rtf_lines
from parsers.rows import (
    SkipLog,
    checked_deviation,
    finish_rows,
    parse_number,
    unit_factor,
    unit_or_none,
    warn_assumed_mm,
)
from parsers.source import read_text
from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["read_ogp", "sniff_ogp"]

_STEP = re.compile(r"^\s*Step:\s+(\d+)\s+(\S+)")
_ROW = re.compile(
    r"^\s*(?:v\s+)?(?P<label>[A-Za-z0-9][A-Za-z0-9 ./#-]*?)"
    r"\s+(?P<nums>[+-]\d+\.\d+(?:\s+[+-]\d+\.\d+)*)\s*(?P<rest>.*)$"
)
_FORM = (
    "flatness",
    "sphericity",
    "cylindricity",
    "circularity",
    "roundness",
    "straightness",
    "true position",
    "position",
    "profile",
    "parallelism",
    "perpendicularity",
    "concentricity",
    "runout",
)
_ANGLE = ("angle", "elevation", "azimuth")
_WORD = re.compile(r"\S+")
_RUN_STEP = re.compile(r"^Step\s+(\d+)\s+-\s*(.*)$")
#: Run-table value columns by start position (``OGP_L123_fixture_sho_multirun.txt``): the
#: heading words do not sit above the values, so positions come from the data rows.
_RUN_COLUMNS = (("nominal", 13, 25), ("actual", 25, 37), ("deviation", 42, 56))


def sniff_ogp(text: str) -> bool:
    """True for an OGP step report (plain or RTF) or run table. Never raises."""
    try:
        if re.search(r"^\s*Step:\s+\d+\s+(MM|IN|INCH)\b", text, re.M | re.I) and "Actual" in text:
            return True
        return "Routine Name" in text and bool(re.search(r"Feature\s+Unit\s+Nominal\s+Actual", text))
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


@lru_cache(maxsize=4096)
def _kind(label: str) -> str:
    low = label.lower()
    if any(word in low for word in _ANGLE):
        return "angle"
    if any(low.startswith(word) for word in _FORM):
        return "form"
    return "length"


def _unit(text: str, default: str | None, where: SourceLocation) -> str:
    unit = unit_or_none(text)
    if unit is None:
        raise ParseError(f"unknown unit {text!r} in the step line", location=where)
    return unit


def _step_report(lines: list[str], name: str, skipped: SkipLog) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    step, factor, table = "", 1.0, ""
    taught_step = False
    for number, line in enumerate(lines, 1):
        where = SourceLocation(name, line=number)
        match = _STEP.match(line)
        if match:
            step, factor = match.group(1), unit_factor(_unit(match.group(2), None, where))
            table, taught_step = "", False
            continue
        words = line.split()
        if "Actual" in words and "Nominal" in words:
            table = "size"
            continue
        if "Actual" in words and "Tolerance" in words:
            table = "form"
            continue
        if not words:
            table = ""
            continue
        row = _ROW.match(line) if table else None
        if not row:
            continue
        label = row.group("label").strip()
        nums = [parse_number(t, where, label) * factor for t in row.group("nums").split()]
        kind = _kind(label)
        if kind == "angle":
            skipped.add("angle row(s) (setupfix corrects lengths)", number)
            continue
        if table == "size":
            if len(nums) != 4:
                raise ParseError(
                    f"{label}: expected Actual Nominal Upper Lower, found {len(nums)} numbers", location=where
                )
            actual, nominal, upper, lower = nums
            if upper == 0 and lower == 0:
                upper = lower = math.nan
                if actual == nominal:
                    taught_step = True
                    skipped.add("row(s) with nominal = actual and no tolerance (taught, no nominal loaded)", number)
                    continue
        else:
            if len(nums) != 2:
                raise ParseError(f"{label}: expected Actual Tolerance, found {len(nums)} numbers", location=where)
            if taught_step and label.lower().startswith("true position"):
                skipped.add("true position row(s) computed against a taught nominal", number)
                continue
            actual, nominal, lower = nums[0], 0.0, math.nan
            upper = nums[1] if nums[1] != 0 else math.nan
        if not math.isnan(lower) and not math.isnan(upper) and lower >= upper:
            raise ParseError(f"lower limit {lower:g} is not below upper limit {upper:g}", location=where)
        rows.append(
            {
                "characteristic": f"Step {step}.{label}",
                "nominal": nominal,
                "actual": actual,
                "deviation": actual - nominal,
                "lower": lower,
                "upper": upper,
                "part": "",
                "timestamp": "",
                "station": "",
                "status": "",
                "source": f"{name}:{number}",
            }
        )
    return rows


def _run_columns(line: str, where: SourceLocation) -> dict[str, str]:
    cells: dict[str, str] = {}
    for match in _WORD.finditer(line, 13):
        start = match.start()
        key = next((k for k, lo, hi in _RUN_COLUMNS if lo <= start < hi), None)
        if key is None or key in cells:
            raise ParseError(
                f"value at column {start + 1} is in a column no sample shows filled (Unit, Tolerances or Exceeded)",
                location=where,
            )
        cells[key] = match.group()
    return cells


def _run_table(lines: list[str], name: str, skipped: SkipLog, factor: float) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    part, stamp, step = "", "", ""
    expect_run = False
    for number, line in enumerate(lines, 1):
        where = SourceLocation(name, line=number)
        text = line.strip()
        if not text or text.startswith(("=", "Machine Serial Number", "Feature ")):
            continue
        if text.startswith("Routine Name"):
            expect_run = True
            continue
        if expect_run:
            expect_run = False
            fields = text.split(None, 2)
            if len(fields) < 3:
                raise ParseError("run line lacks routine, run number or date", location=where)
            try:
                stamp = datetime.strptime(" ".join(fields[2].split()), "%a %b %d %H:%M:%S %Y").isoformat()
            except ValueError:
                raise ParseError(f"run date {fields[2]!r} not understood", location=where) from None
            part = f"run {fields[1]} {stamp}"
            continue
        match = _RUN_STEP.match(text)
        if match:
            step = match.group(1)
            continue
        label = line[:13].strip()
        if not label or not step:
            raise ParseError(f"unexpected line {text[:40]!r}", location=where)
        cells = _run_columns(line, where)
        kind = _kind(label)
        if kind == "angle":
            skipped.add("angle row(s) (setupfix corrects lengths)", number)
            continue
        if "actual" not in cells:
            raise ParseError(f"{label}: no actual value", location=where)
        actual = parse_number(cells["actual"], where, "Actual") * factor
        stated = parse_number(cells["deviation"], where, "Deviation") * factor if "deviation" in cells else None
        if "nominal" in cells:
            nominal = parse_number(cells["nominal"], where, "Nominal") * factor
        elif kind == "form" and stated is not None:
            nominal = 0.0
        else:
            skipped.add("row(s) with an actual value only (no nominal)", number)
            continue
        deviation = checked_deviation(nominal, actual, stated, where, magnitude_ok=True)
        if deviation is None:
            skipped.add("row(s) whose actual and nominal differ in sign (magnitudes compared)", number)
            continue
        rows.append(
            {
                "characteristic": f"Step {step}.{label}",
                "nominal": nominal,
                "actual": actual,
                "deviation": deviation,
                "lower": math.nan,
                "upper": math.nan,
                "part": part,
                "timestamp": stamp,
                "station": "",
                "status": "",
                "source": f"{name}:{number}",
            }
        )
    return rows


def read_ogp(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read an OGP step report (plain or RTF-wrapped) or run table into the canonical table.

    Parameters
    ----------
    path : str or Path
    unit : {"mm", "inch"}, optional
        Unit of the run table, which states none (default mm, with a warning).
        Step reports state the unit on every step.
    encoding : str, optional

    Raises
    ------
    ParseError
        On a malformed row, a contradicting deviation, or no usable length row.
    """
    name = str(path)
    text = read_text(path, encoding)
    lines = rtf_lines(text) if is_rtf(text) else [line.rstrip("\r") for line in text.split("\n")]
    skipped = SkipLog(name)
    if any(_STEP.match(line) for line in lines):
        rows = _step_report(lines, name, skipped)
    elif any(line.strip().startswith("Routine Name") for line in lines):
        default = unit_or_none(unit) if unit else None
        if unit and default is None:
            raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
        rows = _run_table(lines, name, skipped, unit_factor(default or "mm"))
        if rows and default is None:
            warn_assumed_mm(name, str(rows[0]["source"]).rsplit(":", 1)[-1])
    else:
        raise ParseError("neither an OGP step report nor a run table", location=SourceLocation(name))
    return finish_rows(rows, name, skipped, what="OGP")
