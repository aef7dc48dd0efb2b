"""Numbers as setupfix prints them: fixed decimals, never a negative zero.

A value that rounds to zero at the digits shown (``-0.00001`` at four decimals, or ``-0.0``
itself) prints as ``0.0000`` (``+0.0000`` with a sign), never ``-0.0000``: an operator
reading ``-0.0000`` sees a change where there is none.  Every text door (``correct``,
``batch``, the offsets and the TUI) formats its lengths and margins through :func:`fmt`.
"""

from __future__ import annotations

import math

__all__ = ["fmt", "unsigned_zero"]


def unsigned_zero(value: float, digits: int) -> float:
    """``value`` rounded to ``digits`` decimals, a zero result always +0.0."""
    return round(float(value), digits) + 0.0


def fmt(value: float | None, digits: int = 4, *, sign: bool = False, missing: str = "—") -> str:
    """``value`` with ``digits`` decimals (``sign``: always a sign, ``+0.0123``); never ``-0.0000``.

    ``missing`` is shown for None, NaN and ±inf.
    """
    if value is None or not math.isfinite(value):
        return missing
    shown = unsigned_zero(value, digits)
    return f"{shown:+.{digits}f}" if sign else f"{shown:.{digits}f}"
