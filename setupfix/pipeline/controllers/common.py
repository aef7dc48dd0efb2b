"""Helpers shared by the controller renderers: numbers, modes and errors."""

from __future__ import annotations

import re
from collections.abc import Sequence

from setupfix.errors import ExportError
from setupfix.offsets import OffsetRow, format_value, grid_decimals

__all__ = ["number", "target", "cannot", "one_mode", "comment_text"]


def number(row: OffsetRow, value: float) -> str:
    """``value`` signed, with a decimal point always (a bare ``5`` is 5 increments on a Fanuc)."""
    text = format_value(value, max(1, grid_decimals(row.resolution)))
    return text if text.startswith("-") else "+" + text


def target(row: OffsetRow) -> float:
    """What the line writes: the new absolute value (set) or the change (add)."""
    return row.value if row.mode == "set" and row.value is not None else row.delta


def cannot(controller: str, row: OffsetRow, why: str) -> ExportError:
    return ExportError(f"{controller}: cannot express register {row.register!r} ({row.id}): {why}")


def one_mode(rows: Sequence[OffsetRow]) -> str:
    """``add`` or ``set`` — one program never mixes them."""
    modes = {r.mode for r in rows}
    if len(modes) > 1:
        raise ExportError("offsets mix add and set rows: give the current value of every register")
    return modes.pop() if modes else "add"


_UNSAFE = re.compile(r"[^A-Z0-9 .+\-_/#]")


def comment_text(text: str) -> str:
    """Text safe inside a G-code comment: upper case, no parentheses or control characters."""
    return _UNSAFE.sub("_", text.upper())
