"""Korean production CMM text report (CP949), as in ``KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt``.

Layout: a header (품명 part name, 품번 part number, 측정시간 time, 특기사항 remark), the
heading ``번호 항목 측정값 기준값 상한공차 하한공차 편차 판정`` (no., item, actual,
nominal, upper tol., lower tol., deviation, judgement), then per element a line
``  5 원1(I) <상>`` and its item rows.  Columns are right-aligned in *display* columns
(a Hangul syllable or ``°`` is two columns wide, one CP949 double byte), so words are
placed by display width, not by character index.

Items: X Y Z D DS R are lengths; Ang X/Y Y/X are angles (often ``D:MM:SS``) and are
skipped; SMmf rows are point statistics, not characteristics, and are ignored;
form rows (평면도 flatness, 원통도, 진원도, 동심도, 직각도, 평행도, 위치도) give the
actual in the actual column and the tolerance in the nominal column: they are kept
with nominal 0 and the tolerance as upper limit.  Upper and lower tolerances are
signed (the lower one may be positive).  The judgement is a bar relative to the
tolerance-zone centre (kept as ``ok``) or, out of tolerance, the excess (``out``).
An element named ``…#2`` is the second part measured in the same report.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pandas as pd

from parsers.canonical import DEVIATION_TOLERANCE_MM
from parsers.geometry import axis_vector, geometry_cells
from parsers.notes import note
from parsers.rows import SkipLog, finish_rows, parse_number, unit_factor, unit_or_none
from parsers.source import Source, read_text
from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["read_korean", "sniff_korean"]

_LENGTH_ITEMS = frozenset({"X", "Y", "Z", "D", "DS", "R", "L", "W", "H"})
_ANGLE_ITEMS = frozenset({"ANG", "X/Y", "Y/X", "Z/X", "X/Z", "Y/Z", "Z/Y", "A"})
_FORM_ITEMS = frozenset(
    {"평면도", "원통도", "진원도", "동심도", "직각도", "평행도", "위치도", "진직도", "경사도", "대칭도", "윤곽도"}
)
#: Right edges (display columns) of actual, nominal, upper, lower, deviation; judgement after.
_EDGES = (("item", 18), ("actual", 31), ("nominal", 45), ("upper", 59), ("lower", 73), ("deviation", 86))
_ELEMENT = re.compile(r"^\s{0,6}(\d+)\s+(\S+)")
_STAMP = re.compile(r"(\d{4})\.(\d{1,2})\.(\d{1,2})\.?\s+(\d{1,2}):(\d{2}):(\d{2})")
_BAR = re.compile(r"^[-+|]+$")


#: Element words (the name's letters before its number) → the ``feature`` column (:mod:`parsers.geometry`):
#: 원 circle, 원통 cylinder, 평면 plane, 점 point, 직선 line, 구 sphere, 원추 cone, 장공 slot.
_FEATURE_WORDS = {
    "원": "circle",
    "원통": "cylinder",
    "평면": "plane",
    "점": "point",
    "직선": "line",
    "구": "sphere",
    "원추": "cone",
    "장공": "slot",
}
_ELEMENT_WORD = re.compile(r"^([^\d(#<\s]+)")
#: Items that state a size of the element.
_SIZE_ITEMS = {"D": "diameter", "R": "radius"}


def _geometry(element: str, item: str) -> dict[str, object]:
    """The geometry columns of an item row: X/Y/Z a direction, D/R a size; the element's type and
    ``(I)``/``(E)`` side (internal, external)."""
    word = _ELEMENT_WORD.match(element)
    feature = _FEATURE_WORDS.get(word.group(1), "") if word else ""
    side = "inner" if "(I)" in element else "outer" if "(E)" in element else ""
    key = item.upper()
    return geometry_cells(axis_vector(key), feature, _SIZE_ITEMS.get(key, ""), side)


def sniff_korean(text: str) -> bool:
    """True if ``text`` has the 측정값/기준값 heading of this layout. Never raises."""
    try:
        return "측정값" in text and "기준값" in text and "공차" in text
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


def _words(line: str) -> list[tuple[int, int, str]]:
    """Words of ``line`` with their display start and end columns."""
    words: list[tuple[int, int, str]] = []
    col, start, word = 0, 0, ""
    for ch in line:
        width = 2 if ord(ch) > 0x7F else 1
        if ch.isspace():
            if word:
                words.append((start, col, word))
                word = ""
        else:
            if not word:
                start = col
            word += ch
        col += width
    if word:
        words.append((start, col, word))
    return words


def _cells(line: str, where: SourceLocation) -> dict[str, str]:
    cells: dict[str, str] = {}
    for _start, end, word in _words(line):
        key = next((k for k, edge in _EDGES if end <= edge), "judgement")
        if key in cells and key != "judgement":
            raise ParseError(f"two values in the {key} column ({cells[key]!r}, {word!r})", location=where)
        cells[key] = f"{cells[key]} {word}" if key in cells else word
    return cells


def _header_value(text: str, label: str) -> str:
    match = re.search(label + r"\s*:\s*(.*?)(?:\s{2,}|$)", text, re.M)
    return match.group(1).strip() if match else ""


def along_normal(
    nominal: float, actual: float, stated: float | None, lower: float, upper: float
) -> tuple[float, float, float] | None:
    """(nominal, lower, upper) of a row in coordinates, learning the report's sign convention.

    The report states each deviation along the feature's normal.  Where the normal
    points along the axis, ``stated = actual − nominal`` and the row is read as it is.
    Where it points the other way, the stated deviation is the negative:
    ``stated = −(actual − nominal)`` (``Y −2.402`` on ``−2.4`` stated ``+0.002``), and
    the limits, also along the normal, are mirrored into the axis
    (``[lower, upper] → [−upper, −lower]``).  Some rows also print the nominal as the
    distance along that reversed normal (``Y −10.905`` on ``10.9`` stated ``+0.005``):
    ``stated = −(actual + nominal)``; the coordinate nominal is then ``−nominal``.

    Returns
    -------
    (nominal, lower, upper) or None
        In the axis' coordinates (deviation = actual − nominal); None when the stated
        deviation fits none of the three readings (the row contradicts itself).
    """
    tol = DEVIATION_TOLERANCE_MM
    if stated is None or abs(stated - (actual - nominal)) <= tol:
        return nominal, lower, upper
    if abs(stated + (actual - nominal)) <= tol:
        return nominal, -upper, -lower
    if abs(stated + (actual + nominal)) <= tol:
        return -nominal, -upper, -lower
    return None


def read_korean(
    path: str | Path | Source, *, unit: str | None = None, encoding: str | None = None, lenient: bool = False
) -> pd.DataFrame:
    """Read a Korean CMM text report into the canonical table.

    Parameters
    ----------
    path : str or Path
    unit : {"mm", "inch"}, optional
        The report states no unit; its values are mm unless this says otherwise.
    encoding : str, optional
        Sniffed when omitted (CP949 / EUC-KR in every sample).
    lenient : bool
        Skip a row whose stated deviation fits no reading of :func:`along_normal`, with a
        note naming its line, instead of refusing the report.

    Raises
    ------
    ParseError
        On an unknown item, a misplaced value, a contradicting deviation, or no
        usable length row.
    """
    name = str(path)
    factor = 1.0
    if unit:
        known = unit_or_none(unit)
        if known is None:
            raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
        factor = unit_factor(known)
    text = read_text(path, encoding)
    remark = re.sub(r"\s+", "_", _header_value(text, "특기사항")) or Path(name).stem
    stamp_match = _STAMP.search(_header_value(text, "측정시간"))
    stamp = ""
    if stamp_match:
        y, mo, d, hh, mi, ss = stamp_match.groups()
        stamp = f"{y}-{int(mo):02d}-{int(d):02d}T{int(hh):02d}:{mi}:{ss}"
    skipped = SkipLog(name)
    reversed_rows = SkipLog(name)
    rows: list[dict[str, object]] = []
    element, part = "", remark
    in_table = False
    for number, line in enumerate(text.split("\n"), 1):
        where = SourceLocation(name, line=number)
        if not in_table:
            in_table = "측정값" in line and "기준값" in line
            continue
        if not line.strip() or line.lstrip().startswith("---"):
            continue
        head = _ELEMENT.match(line)
        if head:
            base = head.group(2)
            suffix = re.search(r"#(\d+)", base)
            element = re.sub(r"#\d+", "", base)
            part = f"{remark}#{suffix.group(1)}" if suffix and suffix.group(1) != "1" else remark
            continue
        cells = _cells(line, where)
        item = cells.get("item", "")
        if item.upper() == "SMMF":
            continue
        if item.upper() in _ANGLE_ITEMS:
            skipped.add("angle row(s) (setupfix corrects lengths)", number)
            continue
        if not element:
            raise ParseError(f"item row {item!r} before any element line", location=where)
        judgement = cells.get("judgement", "")
        status = "" if not judgement else ("ok" if _BAR.match(judgement) else "out")
        if item in _FORM_ITEMS:
            if "actual" not in cells or "nominal" not in cells:
                raise ParseError(f"{item}: expected value and tolerance", location=where)
            if "upper" in cells or ("lower" in cells and re.match(r"^[-+\d.]+$", cells["lower"])):
                skipped.add("form row(s) with a number in a tolerance column (layout not understood)", number)
                continue
            actual = parse_number(cells["actual"], where, "측정값") * factor
            tolerance = parse_number(cells["nominal"], where, "공차") * factor
            nominal, lower, upper = 0.0, math.nan, tolerance if tolerance > 0 else math.nan
            deviation: float | None = actual
        elif item.upper() in _LENGTH_ITEMS:
            missing = [k for k in ("actual", "nominal", "upper", "lower") if k not in cells]
            if missing:
                raise ParseError(f"{item}: missing {', '.join(missing)}", location=where)
            actual = parse_number(cells["actual"], where, "측정값") * factor
            nominal = parse_number(cells["nominal"], where, "기준값") * factor
            upper = parse_number(cells["upper"], where, "상한공차") * factor
            lower = parse_number(cells["lower"], where, "하한공차") * factor
            if upper == 0 and lower == 0:
                upper = lower = math.nan
            elif lower >= upper:
                raise ParseError(f"lower tolerance {lower:g} is not below upper {upper:g}", location=where)
            stated = parse_number(cells["deviation"], where, "편차") * factor if "deviation" in cells else None
            read = along_normal(nominal, actual, stated, lower, upper)
            if read is None:
                message = (
                    f"stated deviation {stated:g} mm fits neither actual - nominal = {actual - nominal:g} mm "
                    "nor its negative (deviation along a reversed normal)"
                )
                if not lenient:
                    raise ParseError(message, location=where, hint="--lenient skips such rows")
                skipped.add("row(s) contradicting themselves, skipped by --lenient", number)
                continue
            if read[1:] != (lower, upper) and not (math.isnan(lower) and math.isnan(upper)):
                reversed_rows.add("row(s) stating the deviation along a reversed normal (limits mirrored)", number)
            nominal, lower, upper = read
            deviation = actual - nominal
        else:
            raise ParseError(f"unknown item {item!r}", location=where)
        rows.append(
            {
                "characteristic": f"{element}.{item}",
                "nominal": nominal,
                "actual": actual,
                "deviation": deviation,
                "lower": lower,
                "upper": upper,
                "part": part,
                "timestamp": stamp,
                "station": "",
                "status": status,
                "source": f"{name}:{number}",
                **_geometry(element, item),
            }
        )
    if not in_table:
        raise ParseError("no 측정값/기준값 heading found", location=SourceLocation(name))
    table = finish_rows(rows, name, skipped, what="Korean CMM")
    for reason, lines in reversed_rows.reasons.items():
        shown = ", ".join(str(n) for n in lines[:12]) + (", …" if len(lines) > 12 else "")
        note(f"{len(lines)} {reason}: line {shown}", SourceLocation(name, line=int(lines[0])), "convention")
    return table
