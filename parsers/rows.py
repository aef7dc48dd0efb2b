"""Row building shared by the readers of issue 3 (Q-DAS, PC-DMIS, QVPAK, OGP, Korean, PiWeb).

They fix the rules every one of these readers follows, so the six behave alike:

* numbers may carry a decimal comma, an explicit ``+``, zero padding or a bare
  leading dot (``+00020.262``, ``44,158745``, ``.1000``);
* the deviation is always recomputed as actual − nominal; a stated deviation is
  only cross-checked (a contradiction beyond rounding is a :class:`ParseError`);
* a characteristic whose value is not a length (an angle, a count, an attribute) is
  skipped, and every skipped line is named in one note per reason;
* a row without a nominal cannot yield a deviation and is skipped the same way; a
  file left with no usable row is refused with the reason.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import pandas as pd

from parsers import numbers
from parsers.canonical import DEVIATION_TOLERANCE_MM, finish_table
from parsers.notes import note
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS

__all__ = [
    "SkipLog",
    "parse_number",
    "try_number",
    "unit_or_none",
    "unit_factor",
    "checked_deviation",
    "text_columns",
    "split_columns",
    "finish_rows",
    "warn_assumed_mm",
]


def try_number(text: str) -> float | None:
    """The number ``text`` spells (decimal point or comma), else None. Never raises."""
    return numbers.try_number(text, decimal="auto")


def parse_number(text: str, where: SourceLocation, what: str) -> float:
    """Parse a number in report notation (decimal point or comma) with :func:`parsers.numbers.parse_number`.

    Raises
    ------
    ParseError
        If ``text`` is not a finite number.
    """
    return numbers.parse_number(text, decimal="auto", location=where, what=what)


def unit_or_none(text: str) -> str | None:
    """``"mm"``/``"inch"`` for a length-unit spelling, ``"cm"`` for centimetres, else None."""
    key = text.strip().lower()
    if key == "cm":
        return "cm"
    return LENGTH_UNITS.get(key)


def unit_factor(unit: str) -> float:
    """Millimetres per ``unit`` (``"mm"``, ``"inch"`` or ``"cm"``)."""
    return {"mm": 1.0, "inch": 25.4, "cm": 10.0}[unit]


def checked_deviation(
    nominal: float, actual: float, stated: float | None, where: SourceLocation, *, magnitude_ok: bool = False
) -> float | None:
    """Return actual − nominal after checking the report's own deviation against it.

    Parameters
    ----------
    nominal, actual : float
        In mm.
    stated : float or None
        The report's deviation in mm, if it gives one.
    where : SourceLocation
        The line, for the error.
    magnitude_ok : bool
        Accept a stated deviation equal to ``|actual| − |nominal|``: OGP and the Korean
        layout compare magnitudes of coordinates (``OGP_L123_fixture_sho_multirun.txt``
        line 31: Y −113.895 → −113.903 reported as +0.009).

    Returns
    -------
    float or None
        The deviation, or None when actual and nominal have opposite signs and the
        report compared magnitudes: the coordinate deviation is then unknown.

    Raises
    ------
    ParseError
        If the stated deviation contradicts the values beyond rounding.
    """
    deviation = actual - nominal
    if stated is None or abs(stated - deviation) <= DEVIATION_TOLERANCE_MM:
        return deviation
    if magnitude_ok and abs(stated - (abs(actual) - abs(nominal))) <= DEVIATION_TOLERANCE_MM:
        return None if actual * nominal < 0 else deviation
    raise ParseError(f"stated deviation {stated:g} mm contradicts actual - nominal = {deviation:g} mm", location=where)


@dataclass
class SkipLog:
    """Lines a reader left out, grouped by reason; reported as one warning per reason."""

    path: str
    reasons: dict[str, list[int | str]] = field(default_factory=dict)

    def add(self, reason: str, line: int | str) -> None:
        """Record that ``line`` (a number, or ``file:line`` in another file) was skipped for ``reason``."""
        lines = self.reasons.setdefault(reason, [])
        if not lines or lines[-1] != line:
            lines.append(line)

    @property
    def count(self) -> int:
        return sum(len(lines) for lines in self.reasons.values())

    def summary(self) -> str:
        """One phrase per reason with its count and first lines."""
        parts = []
        for reason, lines in self.reasons.items():
            shown = ", ".join(str(n) for n in lines[:8]) + (", …" if len(lines) > 8 else "")
            parts.append(f"{len(lines)} {reason} (line {shown})")
        return "; ".join(parts)

    def warn(self) -> None:
        """Leave one note per reason (:func:`parsers.notes.note`), naming the lines."""
        for reason, lines in self.reasons.items():
            shown = ", ".join(str(n) for n in lines[:20]) + (f", … ({len(lines)} in all)" if len(lines) > 20 else "")
            first = lines[0] if isinstance(lines[0], int) else None
            note(f"skipped {len(lines)} {reason}: line {shown}", SourceLocation(self.path, line=first), "skipped")


def text_columns(header: str, names: dict[str, str]) -> list[tuple[str, int, int]]:
    """Column spans of a fixed-width table from its heading line.

    Parameters
    ----------
    header : str
        The heading line.
    names : dict
        Heading word (upper case) → canonical column key; other words are ignored.

    Returns
    -------
    list of (key, start, end)
        One span per recognised heading word, in order.
    """
    spans = []
    for match in re.finditer(r"\S+", header):
        key = names.get(match.group().upper())
        if key:
            spans.append((key, match.start(), match.end()))
    return spans


def split_columns(line: str, spans: list[tuple[str, int, int]]) -> dict[str, str]:
    """Assign each word of ``line`` to the heading column it lies under.

    A word belongs to the column whose heading overlaps it; failing that, to the
    column whose heading ends nearest to the word's end (values are right-aligned
    under their headings in the vendor layouts seen).  Two words in one column are
    joined by a space.
    """
    cells: dict[str, str] = {}
    for match in re.finditer(r"\S+", line):
        start, end = match.span()
        best = min(spans, key=lambda s: (0 if s[1] < end and start < s[2] else 1, abs(s[2] - end)))
        cells[best[0]] = (cells[best[0]] + " " + match.group()) if best[0] in cells else match.group()
    return cells


def warn_assumed_mm(path: str, first_line: int | str) -> None:
    """Warn once that a report states no unit and its lengths were taken as mm."""
    line = first_line if isinstance(first_line, int) else None
    note(
        "no length unit stated; values taken as mm (give the unit with --unit to override)",
        SourceLocation(path, line=line),
        "unit",
    )


def finish_rows(rows: list[dict[str, object]], path: str, skipped: SkipLog, *, what: str) -> pd.DataFrame:
    """Warn about skipped lines and build the canonical table, or refuse an empty result.

    Parameters
    ----------
    rows : list of dict
        Canonical rows, lengths in mm.
    path : str
        The report.
    skipped : SkipLog
        What was left out and why.
    what : str
        Name of the format, for the refusal message.

    Raises
    ------
    ParseError
        If no row is left: the message says what was skipped.
    """
    if not rows:
        reason = skipped.summary() or "no characteristic found"
        raise ParseError(
            f"{what} report holds no usable length measurement: {reason}",
            location=SourceLocation(path),
            hint="setupfix needs nominal and actual of length characteristics",
        )
    skipped.warn()
    return finish_table(rows, path)
