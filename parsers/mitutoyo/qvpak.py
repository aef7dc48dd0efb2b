"""Mitutoyo Quick Vision (QVPAK) text report, as in ``Mitutoyo_QVPAK_sample1_distances.txt``.

Layout (Portuguese user interface, CP1252, decimal comma)::

            Elemento           Atual         Nominal          Desvio        Tol.sup.        Tol.inf.        De./Fora
    Distância: Distância-1_1(ID:13) entre Ponto-4_1(ID:7) e Ponto-5_1(ID:10)
               DX =        44,158745

An element line ``<type>: <name>(ID:n) …`` is followed by value lines ``<quantity> =``
whose numbers are right-aligned under the heading words; the heading repeats on
every page.  Quantities: DX DY DZ LC (distances), D R (diameter, radius), X Y Z
(coordinates) and Raio (a circle's radius) are lengths; CA (angle) is skipped.  A quantity not
known here is refused only where its row has a nominal: an actual alone is unusable whatever
it measures, and a report of actuals only is refused for that (its real cause).  The report states no unit (mm
assumed, with a warning, unless ``unit=`` says otherwise).

Both public samples fill only the actual column: without nominals no deviation can
be computed, so they are refused with that reason.  How ``Tol.inf.`` is signed is
not shown by any sample; as for PC-DMIS, a report with any negative ``Tol.inf.`` is
read as signed, otherwise as magnitudes.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pandas as pd

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

__all__ = ["read_qvpak", "sniff_qvpak"]

_HEADINGS = {
    "ELEMENTO": "element",
    "ATUAL": "actual",
    "NOMINAL": "nominal",
    "DESVIO": "deviation",
    "TOL.SUP.": "upper",
    "TOL.INF.": "lower",
    "DE./FORA": "verdict",
    "ELEMENT": "element",
    "ACTUAL": "actual",
    "DEVIATION": "deviation",
    "UPPER": "upper",
    "LOWER": "lower",
}
_ELEMENT = re.compile(r"^(?P<type>[^\s:][^:]*):\s+(?P<name>[^\s(]+)")
_VALUE = re.compile(r"^\s+(?P<label>[A-Za-z][A-Za-z0-9]*)\s+=")
#: Length quantities; ``Raio`` is the Portuguese interface's radius of a ``Círculo`` (the upstream
#: repository's sample3.txt).
_LENGTHS = frozenset({"DX", "DY", "DZ", "LC", "D", "R", "X", "Y", "Z", "L", "W", "RAIO"})
_ANGLES = frozenset({"CA", "A", "ANG"})


def sniff_qvpak(text: str) -> bool:
    """True if ``text`` has the QVPAK heading (Elemento … Atual … Nominal … Desvio). Never raises."""
    try:
        return bool(re.search(r"^\s*Elemento\s+Atual\s+Nominal\s+Desvio", text, re.M))
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


def read_qvpak(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a Mitutoyo QVPAK text report into the canonical table.

    Parameters
    ----------
    path : str or Path
    unit : {"mm", "inch"}, optional
        The report states no unit; mm (with a warning) unless given.
    encoding : str, optional
        Sniffed when omitted (CP1252 in the samples).

    Raises
    ------
    ParseError
        On a value line outside an element, an unknown quantity, a non-numeric value,
        a contradicting deviation, or when no row has a nominal.
    """
    name = str(path)
    default = unit_or_none(unit) if unit else None
    if unit and default is None:
        raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
    factor = unit_factor(default or "mm")
    text = read_text(path, encoding)
    skipped = SkipLog(name)
    raw: list[tuple[SourceLocation, str, dict[str, str]]] = []
    spans: list[tuple[str, int, int]] = []
    element = ""
    for number, line in enumerate(text.split("\n"), 1):
        line = line.rstrip("\r")
        where = SourceLocation(name, line=number)
        if sniff_qvpak(line):
            spans = text_columns(line, _HEADINGS)
            continue
        value = _VALUE.match(line)
        if value:
            if not spans or not element:
                raise ParseError("value line before the heading or an element line", location=where)
            label = value.group("label").upper()
            if label in _ANGLES:
                skipped.add("angle row(s) (setupfix corrects lengths)", number)
                continue
            cells = split_columns(line[value.end() :].rjust(len(line)), spans)
            cells.pop("element", None)
            if label not in _LENGTHS:
                if "nominal" not in cells:  # unusable whatever it measures: the cause is the missing nominal
                    skipped.add("row(s) with an actual value only (no nominal)", number)
                    continue
                raise ParseError(f"unknown quantity {label!r}", location=where)
            raw.append((where, f"{element}.{label}", cells))
            continue
        head = _ELEMENT.match(line)
        if head and "(ID:" in line:
            element = head.group("name")
    signed = any((try_number(c.get("lower", "")) or 0.0) < 0 for _, _, c in raw)
    rows: list[dict[str, object]] = []
    for where, characteristic, cells in raw:
        if "actual" not in cells:
            raise ParseError("value line without an actual value", location=where)
        if "nominal" not in cells:
            skipped.add("row(s) with an actual value only (no nominal)", where.line or 0)
            continue
        actual = parse_number(cells["actual"], where, "Atual") * factor
        nominal = parse_number(cells["nominal"], where, "Nominal") * factor
        stated = parse_number(cells["deviation"], where, "Desvio") * factor if "deviation" in cells else None
        upper = parse_number(cells["upper"], where, "Tol.sup.") * factor if "upper" in cells else math.nan
        lower = math.nan
        if "lower" in cells:
            low = parse_number(cells["lower"], where, "Tol.inf.")
            lower = (low if signed else -abs(low)) * factor + 0.0
        if not math.isnan(lower) and not math.isnan(upper) and lower >= upper:
            raise ParseError(f"lower limit {lower:g} is not below upper limit {upper:g}", location=where)
        verdict = cells.get("verdict", "").lower()
        rows.append(
            {
                "characteristic": characteristic,
                "nominal": nominal,
                "actual": actual,
                "deviation": checked_deviation(nominal, actual, stated, where),
                "lower": lower,
                "upper": upper,
                "part": "",
                "timestamp": "",
                "station": "",
                "status": {"de": "ok", "fora": "out"}.get(verdict, verdict),
                "source": f"{name}:{where.line}",
            }
        )
    if rows and default is None:
        warn_assumed_mm(name, str(rows[0]["source"]).rsplit(":", 1)[-1])
    return finish_rows(rows, name, skipped, what="QVPAK")
