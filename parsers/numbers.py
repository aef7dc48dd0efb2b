"""The one number parser every reader uses.

A metrology file writes a number as an optional sign, digits with one decimal mark
and an optional exponent: ``-0.0309``, ``+00020.262``, ``.1000``, ``44,158745``
(decimal comma), ``1.5E-3``.  Python's :func:`float` accepts far more — ``1_000``,
``nan``, ``inf``, ``infinity``, ``0x10`` is refused but the first three are not —
and every one of those in a report is damage, not a value: ``-0_0309`` would be
−309, a QIF ``<MaxValue>NaN</MaxValue>`` "no upper limit".  So the grammar is
checked first, then the value is computed, scaled to mm and checked to be finite
(``1e307`` inch is ``inf`` mm).

The grammar is written here rather than taken from a library because none of the
locale libraries (babel, :mod:`locale`) refuses ``nan``/``_`` or reports the place;
it is one regular expression.
"""

from __future__ import annotations

import math
import re
from typing import Literal

from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["parse_number", "try_number", "is_number", "number_pattern", "Decimal", "MAX_NUMBER_CHARS"]

#: Decimal mark: ``"."`` (point only), ``","`` (comma only) or ``"auto"`` (point, or a comma
#: when the text has exactly one and no point — every decimal-comma report in the samples).
Decimal = Literal[".", ",", "auto"]

#: Longest number text accepted: a double holds 17 significant digits, a report prints at most
#: about 20 characters; a 401-digit integer is damage (and slow to convert).
MAX_NUMBER_CHARS = 40

_GRAMMAR = {
    ".": re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d{1,5})?", re.ASCII),
    ",": re.compile(r"[+-]?(?:\d+(?:,\d*)?|,\d+)(?:[eE][+-]?\d{1,5})?", re.ASCII),
    "auto": re.compile(r"[+-]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][+-]?\d{1,5})?", re.ASCII),
}


def number_pattern(decimal: Decimal = ".") -> re.Pattern[str]:
    """The grammar as a compiled pattern (for vectorised checks, e.g. ``Series.str.fullmatch``)."""
    return _GRAMMAR[decimal]


def try_number(text: str, *, decimal: Decimal = ".", scale: float = 1.0) -> float | None:
    """The finite number ``text`` spells (times ``scale``), else None. Never raises.

    Parameters
    ----------
    text : str
        The field, surrounding white space allowed.
    decimal : {".", ",", "auto"}
        Decimal mark accepted.
    scale : float
        Factor applied (a unit conversion to mm); a product that overflows is not a number.
    """
    text = text.strip()
    if len(text) > MAX_NUMBER_CHARS or decimal not in _GRAMMAR or not _GRAMMAR[decimal].fullmatch(text):
        return None
    value = float(text.replace(",", ".")) * scale
    return value if math.isfinite(value) else None


def is_number(text: str, *, decimal: Decimal = ".") -> bool:
    """True when :func:`try_number` reads ``text``."""
    return try_number(text, decimal=decimal) is not None


def parse_number(
    text: str,
    *,
    decimal: Decimal = ".",
    location: SourceLocation | None = None,
    what: str = "",
    scale: float = 1.0,
    allow_empty: bool = False,
) -> float:
    """Parse one number as a metrology file writes it.

    Parameters
    ----------
    text : str
        The field (white space around it is ignored).
    decimal : {".", ",", "auto"}
        Decimal mark: point, comma, or either (a comma only when it is the single mark).
    location : SourceLocation, optional
        File and line/element, named in the error.
    what : str
        The field's name (column, element, K-field), named in the error.
    scale : float
        Factor to apply (unit → mm); the scaled value must be finite too.
    allow_empty : bool
        Empty text gives NaN instead of an error.

    Returns
    -------
    float
        ``value * scale``, finite (or NaN for allowed empty text).

    Raises
    ------
    ParseError
        At ``location`` when the text is not a number in this grammar (``1_000``, ``nan``,
        ``inf``, hex, over :data:`MAX_NUMBER_CHARS` characters) or its scaled value overflows.
    """
    stripped = text.strip()
    if not stripped and allow_empty:
        return math.nan
    value = try_number(stripped, decimal=decimal, scale=scale)
    if value is not None:
        return value
    prefix = f"{what}: " if what else ""
    shown = stripped if len(stripped) <= 30 else stripped[:27] + "..."
    if try_number(stripped, decimal=decimal) is not None:
        raise ParseError(f"{prefix}{shown!r} is beyond the range of a length", location=location)
    raise ParseError(f"{prefix}expected a number, found {shown!r}", location=location)
