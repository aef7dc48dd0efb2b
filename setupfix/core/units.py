"""Length units at the boundaries.

Internally a process model works in its own unit (``[process] unit``); readers
normalise reports to millimetres.  Conversions happen here and nowhere else.
"""

from __future__ import annotations

from typing import Final

__all__ = ["MM_PER_INCH", "LENGTH_UNITS", "normalise_unit", "length_factor"]

MM_PER_INCH: Final[float] = 25.4

#: Accepted spellings of each length unit, lower case.
LENGTH_UNITS: Final[dict[str, str]] = {
    "mm": "mm",
    "millimeter": "mm",
    "millimetre": "mm",
    "millimeters": "mm",
    "millimetres": "mm",
    "inch": "inch",
    "in": "inch",
    "inches": "inch",
    '"': "inch",
}


def normalise_unit(text: str) -> str:
    """Return ``"mm"`` or ``"inch"`` for a unit spelling.

    Raises
    ------
    KeyError
        If the spelling is not a known length unit (callers add the location).
    """
    return LENGTH_UNITS[text.strip().lower()]


def length_factor(from_unit: str, to_unit: str) -> float:
    """Factor that converts a length in ``from_unit`` to ``to_unit``.

    Examples
    --------
    >>> length_factor("inch", "mm")
    25.4
    """
    src, dst = normalise_unit(from_unit), normalise_unit(to_unit)
    if src == dst:
        return 1.0
    return MM_PER_INCH if src == "inch" else 1.0 / MM_PER_INCH
