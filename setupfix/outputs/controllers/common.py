"""Helpers shared by the controller renderers: numbers, modes, register groups, program numbers and errors."""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence

from parsers.current import MAX_OFFSET_MM
from setupfix.core.errors import ExportError
from setupfix.core.units import length_factor
from setupfix.correction.offsets import OffsetRow, format_value, grid_decimals
from setupfix.model.slots import tool_hd

__all__ = [
    "tool_letter",
    "number",
    "target",
    "cannot",
    "one_mode",
    "comment_text",
    "groups",
    "length_unit",
    "base_id",
    "ROTATION",
    "RADIUS",
    "DEFAULT_PROGRAM",
    "PROGRAM_NUMBERS",
    "check_program_number",
    "check_values",
    "value_bound",
    "slot_within",
    "plan_number",
    "PLANS",
    "GUARD_VARIABLE",
    "GUARD_R",
]

#: The component of a WKS rotation about the spindle axis (degrees) and of a tool radius.
ROTATION, RADIUS = "C", "R"

#: Program number written when the caller gives none (the renderers' own default; the doors —
#: :func:`setupfix.usecases.export.export`, batch — always give one, derived so programs do not collide).
DEFAULT_PROGRAM = 4501

#: Program numbers each format can hold (inclusive); a format missing here has no program name.
#: Fanuc ``O1``…``O9999`` (four digits); Haas ``O1``…``O99999`` (five digits); Siemens names the
#: program ``SETUPFIX_<n>`` (a name of at most 24 characters: up to 15 digits, held to 8 here).
PROGRAM_NUMBERS: dict[str, tuple[int, int]] = {
    "fanuc": (1, 9999),
    "haas": (1, 99999),
    "siemens": (1, 99_999_999),
    "fanuc-macro": (1, 9999),
    "haas-macro": (1, 99999),
}


#: The numbers :func:`plan_number` gives (inclusive): at most 7 digits, which a Fanuc macro constant holds exactly
#: (8 at most), never 0 (a vacant variable equals 0 in some comparisons).
PLANS = (1, 9_999_999)
#: Where an incremental (add) program leaves its plan number when it has run, so that a second run stops:
#: the Fanuc/Haas common variable ``#549`` (the last of ``#500``…``#549``, kept at power off on every Fanuc
#: and Haas control) and the Siemens R parameter ``R99`` (the last of the 100 every 840D has; retained).
GUARD_VARIABLE, GUARD_R = 549, "R99"


def plan_number(*parts: str) -> int:
    """The number of an incremental program's plan, from its text (title, program number, every change): the
    same plan always gets the same number, another plan one of :data:`PLANS` by a hash (SHA-256)."""
    low, high = PLANS
    digest = hashlib.sha256("\n".join(parts).encode("utf-8", "backslashreplace")).digest()
    return low + int.from_bytes(digest[:8], "big") % (high - low + 1)


def check_program_number(controller: str, n: int) -> int:
    """``n`` when format ``controller`` can hold it (any number for a format without a program name).

    Raises
    ------
    ExportError
        Naming the format and the numbers it holds.
    """
    span = PROGRAM_NUMBERS.get(controller)
    if span is not None and not span[0] <= n <= span[1]:
        raise ExportError(f"{controller}: program number {n} outside {span[0]}…{span[1]} (--program-number)")
    return n


def value_bound(row: OffsetRow) -> tuple[float, str]:
    """The bound on any value a row writes, and its unit: the one bound of the current-offsets reader
    (:data:`parsers.current.MAX_OFFSET_MM`, 100 m, in the row's unit; a rotation the same number of degrees)."""
    if row.kind == "wks" and row.axis == ROTATION:
        return MAX_OFFSET_MM, "degrees"
    return MAX_OFFSET_MM * length_factor("mm", row.unit), row.unit


def check_values(controller: str, rows: Sequence[OffsetRow]) -> None:
    """Refuse a row whose change, current or new value is as large as :func:`value_bound` or not finite:
    no control holds it, so it is a misread or a unit error, never a value to write.

    Raises
    ------
    ExportError
        Naming the register, the value and the bound.
    """
    for row in rows:
        bound, unit = value_bound(row)
        for what, value in (("change", row.delta), ("current value", row.current), ("new value", row.value)):
            if value is not None and not abs(value) < bound:  # NaN fails too
                raise cannot(
                    controller,
                    row,
                    f"{what} {value:g} is beyond any control's offset range (|value| < {bound:g} {unit})",
                )


def slot_within(controller: str, row: OffsetRow, what: str, n: int, low: int, high: int) -> int:
    """``n`` when the control has that slot (``low`` … ``high``), else an :class:`ExportError` naming it."""
    if not low <= n <= high:
        raise cannot(controller, row, f"{what} {n} does not exist on this control ({low}…{high})")
    return n


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


def groups(rows: Sequence[OffsetRow]) -> list[list[OffsetRow]]:
    """Rows grouped by (kind, register), in order of first appearance: the components of one WKS
    (``W1.X``, ``W1.Y``, ``W1.Z``, ``W1.C``) together; a one-axis row is a group of its own."""
    out: dict[tuple[str, str], list[OffsetRow]] = {}
    for row in rows:
        out.setdefault((row.kind, row.register.strip().casefold()), []).append(row)
    return list(out.values())


def base_id(row: OffsetRow) -> str:
    """The register's model ID without its component (``W1`` of ``W1.X``)."""
    head, dot, tail = row.id.rpartition(".")
    return head if dot and tail == row.axis else row.id


def length_unit(rows: Sequence[OffsetRow]) -> str:
    """The length unit of the rows (a rotation row's degrees do not count), ``mm`` when none has one."""
    return next((r.unit for r in rows if r.axis != ROTATION), "mm")


_UNSAFE = re.compile(r"[^A-Z0-9 .+\-_/#]")


def comment_text(text: str) -> str:
    """Text safe inside a G-code comment: upper case, no parentheses or control characters."""
    return _UNSAFE.sub("_", text.upper())


def tool_letter(controller: str, row: OffsetRow) -> tuple[str, int]:
    """A tool row's register as a Fanuc-family control names it: ``("H", n)`` for a length, ``("D", n)``
    for a radius (``Hn``/``Dn``, else the model's ``number``); a letter that does not match the row's
    kind is refused (a length change written to a D register would change the diameter)."""
    found = tool_hd(row.register)
    fallback = "D" if row.axis == RADIUS else "H"
    letter, n = found if found else (fallback, row.number) if row.number is not None else (None, None)
    if letter is None or n is None:
        raise cannot(controller, row, "a tool register is Hn or Dn, or give number = n in the model")
    if row.axis == RADIUS and letter != "D":
        raise cannot(controller, row, "a tool radius is a D register (Dn)")
    if row.axis != RADIUS and letter != "H":
        raise cannot(controller, row, f"a D register holds the radius/diameter; a tool length is an H register (H{n})")
    return letter, n
