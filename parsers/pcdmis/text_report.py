"""Hexagon PC-DMIS text report: legacy ``DIM`` blocks with an ``AX NOMINAL +TOL -TOL MEAS …`` table.

Layout (Hexagon help, *Dimension Command Format*; no public real report exists, see
``sample_reports/pcdmis/README.md``)::

    PART NAME  : BRACKET-7
    REV NUMBER : B     SER NUMBER : 0041     STATS COUNT : 12
    DIM LOC1= LOCATION OF CIRCLE CIR1  UNITS=MM ,$
    GRAPH=OFF  TEXT=OFF  MULT=10.00  OUTPUT=BOTH
    AX    NOMINAL       +TOL       -TOL       MEAS        DEV     OUTTOL
    X      50.0000     0.0500     0.0500    50.0123     0.0123     0.0000 ----#----
    END OF DIMENSION LOC1

The column set is configurable in PC-DMIS, so columns are taken from each block's
heading line by position.  ``UNITS=`` may change from block to block.  ``-TOL`` is a
positive magnitude unless the routine sets *minus tolerances show negative*; the
report does not say which, so a report in which any ``-TOL`` is negative is read as
signed, any other as magnitudes.  Every ``PART NAME`` header starts a new part.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from parsers.geometry import axis_vector, geometry_cells
from parsers.pcdmis.axes import ANGLE_AXES, NON_LENGTH_AXES
from parsers.rows import (
    SkipLog,
    checked_deviation,
    finish_rows,
    parse_number,
    split_columns,
    text_columns,
    try_number,
    unit_factor,
    unit_or_none,
    warn_assumed_mm,
)
from parsers.source import read_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.model.measurements import ACTUAL_POSITION_COLUMNS, BETWEEN_COLUMN, FEATURE_ID_COLUMN

__all__ = ["read_pcdmis_text", "sniff_pcdmis_text"]

_DIM = re.compile(r"^\s*DIM\s+(?P<name>[^=\s]+)\s*=\s*(?P<rest>.*)$")
_UNITS = re.compile(r"UNITS\s*=\s*(?P<unit>[A-Za-z]+)")
_HEADINGS = {
    "AX": "axis",
    "NOMINAL": "nominal",
    "NOM": "nominal",
    "+TOL": "plus",
    "-TOL": "minus",
    "MEAS": "meas",
    "DEV": "dev",
    "OUTTOL": "outtol",
    "OUT-TOL": "outtol",
    "MAX": "max",
    "MIN": "min",
    "BONUS": "bonus",
}
_HEADER_FIELD = re.compile(r"(PART NAME|REV NUMBER|SER NUMBER|STATS COUNT)\s*:[ \t]*(.*?)(?=\s{2,}|\t|$)")
_BAR = re.compile(r"^[-#<>|+]+$")


def sniff_pcdmis_text(text: str) -> bool:
    """True if ``text`` holds a PC-DMIS ``DIM … =`` block and its ``AX`` heading. Never raises."""
    try:
        return bool(re.search(r"^\s*DIM \S+\s*=", text, re.M) and re.search(r"^\s*AX\s+NOM", text, re.M))
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


@dataclass
class RawRecord:
    """One axis row before the report-wide minus-tolerance convention is known."""

    name: str
    axis: str
    cells: dict[str, str]
    unit: str
    part: str
    where: SourceLocation
    extra: dict[str, str] = field(default_factory=dict)


def _part_label(header: dict[str, str], count: int) -> str:
    if header.get("SER NUMBER"):
        return header["SER NUMBER"]
    stats = header.get("STATS COUNT")
    base = header.get("PART NAME") or "part"
    return f"{base}#{stats or count}"


def _collect(text: str, name: str, default_unit: str | None, skipped: SkipLog) -> list[RawRecord]:
    raws: list[RawRecord] = []
    header: dict[str, str] = {}
    parts_seen = 0
    dim: str | None = None
    unit: str | None = None
    spans: list[tuple[str, int, int]] = []
    for number, line in enumerate(text.splitlines(), 1):
        where = SourceLocation(name, line=number)
        stripped = line.strip()
        fields = _HEADER_FIELD.findall(line)
        if fields:
            if any(k == "PART NAME" for k, _ in fields):
                header, parts_seen = {}, parts_seen + 1
            header.update({k: v for k, v in fields})
            continue
        match = _DIM.match(line)
        if match:
            dim, spans = match.group("name"), []
            feature = _feature_of(match.group("rest"))
            names = _feature_names(match.group("rest"))
            found = _UNITS.search(match.group("rest"))
            unit = unit_or_none(found.group("unit")) if found else default_unit
            if found and unit is None:
                raise ParseError(f"unknown UNITS={found.group('unit')}", location=where)
            continue
        if not stripped or stripped.startswith("END OF DIMENSION"):
            spans = []
            if stripped:
                dim = None
            continue
        if dim is None:
            continue
        if re.match(r"AX\s", stripped):
            spans = text_columns(line, _HEADINGS)
            if not {"axis", "nominal", "meas"} <= {s[0] for s in spans}:
                raise ParseError("heading lacks AX, NOMINAL or MEAS", location=where)
            continue
        if not spans:
            continue  # GRAPH=… option lines and free text between blocks
        cells = split_columns(line, spans)
        axis = cells.get("axis", "")
        if axis.upper() in ANGLE_AXES or axis.upper() in NON_LENGTH_AXES:
            skipped.add(
                f"non-length characteristic(s) (axis {axis})"
                if axis.upper() in NON_LENGTH_AXES
                else "angle characteristic(s) (setupfix corrects lengths)",
                number,
            )
            continue
        raws.append(
            RawRecord(
                dim,
                axis,
                cells,
                unit or "",
                _part_label(header, max(parts_seen, 1)),
                where,
                {k: v for k, v in (("feature", feature), *names.items()) if v},
            )
        )
    return raws


#: ``LOCATION OF CIRCLE CIR1``: the feature word of a location dimension → the ``feature`` column.
_OF_FEATURE = re.compile(r"\bLOCATION\s+OF\s+(?P<word>[A-Z]+)", re.IGNORECASE)
_FEATURE_WORDS = {
    "CIRCLE": "circle",
    "CYLINDER": "cylinder",
    "SPHERE": "sphere",
    "CONE": "cone",
    "PLANE": "plane",
    "POINT": "point",
    "LINE": "line",
    "SLOT": "slot",
}
#: Axis letters that state a size (Hexagon help, *Location Axes*: D diameter, R radius).
_SIZE_LETTERS = {"D": "diameter", "R": "radius"}


#: ``… OF CIRCLE CIR1`` (a location, a true position): the feature's name; ``… FROM CIRCLE CIR1 TO CIRCLE
#: CIR2`` (a distance, an angle): the two it is measured between.
_OF_NAME = re.compile(r"\bOF\s+[A-Z]+\s+(?P<name>[^\s,$]+)", re.IGNORECASE)
_BETWEEN = re.compile(r"\bFROM\s+[A-Z]+\s+(?P<a>[^\s,$]+)\s+TO\s+[A-Z]+\s+(?P<b>[^\s,$]+)", re.IGNORECASE)


def _feature_names(text: str) -> dict[str, str]:
    """``feature_id`` or ``between`` of a ``DIM … =`` header (:mod:`setupfix.model.measurements`)."""
    found = _BETWEEN.search(text)
    if found:
        return {BETWEEN_COLUMN: f"{found.group('a')};{found.group('b')}"}
    found = _OF_NAME.search(text)
    return {FEATURE_ID_COLUMN: found.group("name")} if found else {}


def _feature_of(text: str) -> str:
    """The feature type a ``DIM … = LOCATION OF <type> …`` header states, else ""."""
    found = _OF_FEATURE.search(text)
    return _FEATURE_WORDS.get(found.group("word").upper(), "") if found else ""


def geometry_of(axis: str, feature: str = "") -> dict[str, object]:
    """The geometry columns of an axis row: X/Y/Z a direction, D/R a size (:mod:`parsers.geometry`)."""
    letter = axis.strip().upper()
    return geometry_cells(axis_vector(letter), feature, _SIZE_LETTERS.get(letter, ""))


def _value(cells: dict[str, str], key: str, where: SourceLocation) -> float | None:
    cell = cells.get(key)
    if not cell:
        return None
    number = try_number(cell)
    if number is not None:
        return number
    text = cell.split()
    text = [t for t in text if not _BAR.match(t)]
    if not text:
        return None
    if len(text) > 1:
        raise ParseError(f"column {key}: two values {' '.join(text)!r}", location=where)
    return parse_number(text[0], where, key.upper())


def rows_from_raw(raws: list[RawRecord], name: str, skipped: SkipLog, *, what: str) -> pd.DataFrame:
    """Turn axis rows into canonical rows (shared with the CSV reader).

    Raises
    ------
    ParseError
        On a non-numeric value, a deviation or OUTTOL that contradicts the values, or
        when no length row is left.
    """
    signed_minus = any(
        (try_number(r.cells.get("minus", "").split()[0]) or 0.0) < 0 for r in raws if r.cells.get("minus", "").split()
    )
    rows: list[dict[str, object]] = []
    kept: list[RawRecord] = []
    unstated = False
    for raw in raws:
        where = raw.where
        factor = unit_factor(raw.unit) if raw.unit else 1.0
        unstated |= not raw.unit
        nominal = _value(raw.cells, "nominal", where)
        meas = _value(raw.cells, "meas", where)
        if nominal is None or meas is None:
            skipped.add("row(s) without nominal or measured value", where.line or 0)
            continue
        nominal, meas = nominal * factor, meas * factor
        dev = _value(raw.cells, "dev", where)
        deviation = checked_deviation(nominal, meas, None if dev is None else dev * factor, where)
        plus, minus = _value(raw.cells, "plus", where), _value(raw.cells, "minus", where)
        upper = math.nan if plus is None else plus * factor
        lower = math.nan if minus is None else (minus if signed_minus else -abs(minus)) * factor + 0.0
        if not math.isnan(lower) and not math.isnan(upper) and lower > upper:
            raise ParseError(f"-TOL {minus:g} lies above +TOL {plus:g}", location=where)
        outtol = _value(raw.cells, "outtol", where)
        if outtol is not None and deviation is not None:
            expected = max(deviation - upper, 0.0) if not math.isnan(upper) else 0.0
            if not math.isnan(lower) and deviation < lower:
                expected = lower - deviation
            if abs(abs(outtol * factor) - expected) > max(0.0011, 0.00011 * factor):
                raise ParseError(
                    f"OUTTOL {outtol:g} contradicts the deviation and tolerances "
                    f"(expected {expected / factor:g}); is -TOL signed?",
                    location=where,
                )
        rows.append(
            {
                "characteristic": f"{raw.name}.{raw.axis}" if raw.axis else raw.name,
                "nominal": nominal,
                "actual": meas,
                "deviation": deviation,
                "lower": lower,
                "upper": upper,
                "part": raw.part,
                "timestamp": raw.extra.get("timestamp", ""),
                "station": "",
                "status": "" if outtol is None else ("out" if outtol != 0 else "ok"),
                "source": f"{name}:{where.line}",
                **geometry_of(raw.axis, raw.extra.get("feature", "")),
                FEATURE_ID_COLUMN: raw.extra.get(FEATURE_ID_COLUMN, ""),
                BETWEEN_COLUMN: raw.extra.get(BETWEEN_COLUMN, ""),
            }
        )
        kept.append(raw)
    _positions(rows, kept)
    if rows and unstated:
        first_line = next(r.where.line for r in raws if not r.unit)
        assert first_line is not None  # _collect locates every row by its line number
        warn_assumed_mm(name, first_line)
    return finish_rows(rows, name, skipped, what=what)


def _positions(rows: list[dict[str, object]], kept: list[RawRecord]) -> None:
    """Fill ``x, y, z`` and ``x_actual, y_actual, z_actual`` of every row of a dimension block (one
    part) from its X, Y and Z axis rows (a location's or true position's coordinates): nominal and
    measured, in mm; NaN for an axis the block does not state (``LOC2`` gives X and Z only)."""
    blocks: dict[tuple[str, str], list[int]] = {}
    for i, raw in enumerate(kept):
        blocks.setdefault((raw.part, raw.name), []).append(i)
    for members in blocks.values():
        nominal = [math.nan] * 3
        actual = [math.nan] * 3
        for i in members:
            k = "XYZ".find(kept[i].axis.strip().upper()) if len(kept[i].axis.strip()) == 1 else -1
            if k >= 0:
                nominal[k], actual[k] = float(rows[i]["nominal"]), float(rows[i]["actual"])  # type: ignore[arg-type]  # numbers
        for i in members:
            rows[i].update(zip(("x", "y", "z"), nominal, strict=True))
            rows[i].update(zip(ACTUAL_POSITION_COLUMNS, actual, strict=True))


def read_pcdmis_text(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a PC-DMIS text report into the canonical table.

    Parameters
    ----------
    path : str or Path
    unit : {"mm", "inch"}, optional
        Unit of blocks without ``UNITS=`` (default mm, with a warning).
    encoding : str, optional
        Sniffed when omitted (PC-DMIS writes Windows code pages).

    Raises
    ------
    ParseError
        On a malformed block or value, a contradiction, or no length row.
    """
    name = str(path)
    default_unit = unit_or_none(unit) if unit else None
    if unit and default_unit is None:
        raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
    skipped = SkipLog(name)
    raws = _collect(read_text(path, encoding), name, default_unit, skipped)
    return rows_from_raw(raws, name, skipped, what="PC-DMIS")
