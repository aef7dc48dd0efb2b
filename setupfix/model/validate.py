"""Checks shared by the model loaders: problems collected with key paths and lines, typed values.

:class:`Problems` gathers every problem of a model file (key path, line when the text is
known) before one :class:`~setupfix.core.errors.ModelError` is raised; the small readers below
(:func:`number`, :func:`weights`, :func:`table_of` …) add a problem and return a fallback
instead of raising, so one pass reports everything.  Used by :mod:`setupfix.model.loader` and
:mod:`setupfix.model.tables` (one-axis and common keys) and :mod:`setupfix.model.axes` (multi-axis keys).
"""

from __future__ import annotations

import math
import re
import sys
import unicodedata
from collections.abc import Mapping
from typing import Any

from setupfix.core.errors import ModelError, SourceLocation
from setupfix.core.units import length_factor
from setupfix.model.process import Register
from setupfix.model.slots import register_slots, tool_hd

__all__ = [
    "RANGES_MM",
    "MAX_WEIGHT",
    "Lines",
    "Problems",
    "show",
    "is_number",
    "number",
    "control_free",
    "table_of",
    "weights",
    "Ranges",
    "section_of",
    "check_slots",
    "check_letters",
]

#: Allowed ranges of lengths [mm], converted to the model unit when checked.
RANGES_MM: dict[str, tuple[float, float]] = {
    "resolution": (1e-6, 1.0),
    "limit": (1e-6, 10.0),
    "nominal": (-1e5, 1e5),
    "tolerance": (-100.0, 100.0),
    "position": (-1e5, 1e5),
}
#: Bound on the absolute value of a relation weight.
MAX_WEIGHT = 1000.0


_HEADER = re.compile(r"^\s*\[\[?\s*([^\[\]]+?)\s*\]\]?\s*(?:#.*)?$")
_ASSIGN = re.compile(r"""^\s*["']?([^"'=\s]+)["']?\s*=""")


class Lines:
    """Line of a key path in the model's text: its own ``key =`` line, else its table's header.

    Enough for the files people write (``[wks.W5]`` then ``register = …``); a key it
    cannot place gets no line, only its key path.
    """

    def __init__(self, text: str | None) -> None:
        self.tables: dict[str, int] = {}
        self.assigned: dict[str, int] = {}
        table = ""
        for number, line in enumerate((text or "").splitlines(), 1):
            header = _HEADER.match(line)
            if header:
                table = ".".join(part.strip().strip("\"'") for part in header.group(1).split("."))
                self.tables.setdefault(table, number)
                continue
            assign = _ASSIGN.match(line)
            if assign:
                self.assigned.setdefault(f"{table}.{assign.group(1)}" if table else assign.group(1), number)

    def __call__(self, key: str) -> int | None:
        parts = key.split(".")
        for n in range(len(parts), 0, -1):
            head = ".".join(parts[:n])
            if head in self.assigned:
                return self.assigned[head]
            if head in self.tables:
                return self.tables[head]
        return None


class Problems:
    """Collects problems with their key paths (and lines, when the text is known)."""

    def __init__(self, path: str, origin: Mapping[str, str] | None = None, text: str | None = None) -> None:
        self.path = path
        self.origin = origin or {}
        self.items: list[ModelError] = []
        self.line_of = Lines(text)

    def add(self, key: str, message: str) -> None:
        where = self._where(key)
        self.items.append(ModelError(message, location=SourceLocation(self.path, line=self.line_of(where), key=where)))

    def _where(self, key: str) -> str:
        """Key path in the file as written (templated tables name their template and station)."""
        parts = key.split(".")
        for n in range(min(len(parts), 2), 1, -1):
            head = ".".join(parts[:n])
            if head in self.origin:
                return ".".join([self.origin[head], *parts[n:]])
        return key

    def raise_if_any(self) -> None:
        if self.items:
            text = "\n".join(str(p) for p in self.items)
            err = ModelError(text)
            err.problems = tuple(self.items)
            raise err


def show(value: Any) -> str:
    """A value for a message: short, never failing (huge integers, deep tables)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return f"an integer of {len(str(abs(value))) if value.bit_length() < 13000 else 'thousands of'} digits"
    if isinstance(value, (dict, list)):
        return f"a {'table' if isinstance(value, dict) else 'list'}"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def is_number(value: Any) -> bool:
    """A finite TOML number that fits a float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if isinstance(value, int):
        return abs(value) <= sys.float_info.max
    return math.isfinite(value)


def number(
    p: Problems,
    key: str,
    value: Any,
    *,
    positive: bool = False,
    within: tuple[float, float] | None = None,
    unit: str = "",
) -> float | None:
    if not is_number(value):
        why = (
            "not finite or beyond the float range"
            if isinstance(value, (int, float)) and not isinstance(value, bool)
            else "expected a number"
        )
        p.add(key, f"{why}, found {show(value)}")
        return None
    number = float(value)
    if positive and number <= 0:
        p.add(key, f"must be > 0, found {show(value)}")
        return None
    if within is not None and not within[0] <= number <= within[1]:
        p.add(key, f"{number:g}{unit} is outside the allowed range [{within[0]:g}, {within[1]:g}]{unit}")
        return None
    return number


def control_free(p: Problems, key: str, text: str, what: str) -> bool:
    """An ID (table key, register name): no control character (a table row, a program line would break).

    Control characters are Unicode categories Cc (tab, newline, escape …), Zl and Zp
    (line and paragraph separators); other blanks (no-break space) are kept.
    """
    bad = next((c for c in text if unicodedata.category(c) in ("Cc", "Zl", "Zp")), None)
    if bad is None:
        return True
    p.add(
        key,
        f"{what} {text!r} holds the control character U+{ord(bad):04X}; IDs and names are one line of printable text",
    )
    return False


def table_of(p: Problems, key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        p.add(key, f"expected a table, found {type(value).__name__}")
        return {}
    return dict(value)


def weights(p: Problems, key: str, value: Any, known: Mapping[str, Any], what: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for ref, weight in table_of(p, key, value).items():
        if ref not in known:
            p.add(f"{key}.{ref}", f"unknown {what} {ref!r}")
            continue
        w = number(p, f"{key}.{ref}", weight, within=(-MAX_WEIGHT, MAX_WEIGHT))
        if w is not None and w != 0.0:
            out[ref] = w
    return out


class Ranges:
    """The sanity ranges converted to the model unit."""

    def __init__(self, unit: str) -> None:
        f = length_factor("mm", unit)
        self.unit = f" {unit}"
        self.of = {name: (lo * f, hi * f) for name, (lo, hi) in RANGES_MM.items()}


def section_of(reg: Register) -> str:
    """The table a register (component) comes from: ``wks.W1`` for ``W1.X``."""
    return f"{'wks' if reg.kind == 'wks' else 'tools'}.{reg.base}"


def check_letters(p: Problems, registers: list[Register]) -> None:
    """A tool register whose letter names another kind of offset: a length named ``Dn`` (a Fanuc/Haas
    radius/diameter offset, ``G10 L12``/``L13``) or a radius named ``Hn`` (a length offset).  A program
    would write the change to the wrong offset, so the model is refused naming the key."""
    for reg in registers:
        found = tool_hd(reg.register) if reg.kind == "tool" else None
        if found is None:
            continue
        letter, n = found
        if reg.component == "R" and letter == "H":
            p.add(
                f"tools.{reg.base}.radius",
                f"register {reg.register!r} is an H (tool length) offset; a radius goes to a D register (D{n})",
            )
        elif reg.component != "R" and letter == "D":
            p.add(
                f"tools.{reg.base}.register",
                f"register {reg.register!r} is a D (radius/diameter) offset; a tool length goes to an H "
                f"register (H{n}): the program would write the length change to the diameter",
            )


def check_slots(p: Problems, registers: list[Register]) -> None:
    """Two registers addressing one controller slot (``H5``/``H05``, ``G110``/``G154 P1``, ``number``),
    and a tool register whose letter names another kind of offset (:func:`check_letters`)."""
    check_letters(p, registers)
    owner: dict[str, Register] = {}
    seen: set[tuple[str, str]] = set()
    for reg in registers:
        if (reg.base, reg.register) in seen:  # the components of one WKS share its register
            continue
        seen.add((reg.base, reg.register))
        number_ = None if reg.component == "R" else reg.policy.number  # a radius register names its own slot
        for slot in sorted(register_slots(reg.kind, reg.register, number_, reg.policy.edge)):
            first = owner.setdefault(slot, reg)
            if first is not reg:
                line = p.line_of(p._where(f"{section_of(first)}.register"))
                p.add(
                    f"{section_of(reg)}.register",
                    f"register {reg.register!r} addresses the controller slot {slot}, also used by "
                    f"{first.id} ([{section_of(first)}]{f' line {line}' if line else ''}, register {first.register!r}"
                    + (f", number = {first.policy.number}" if first.policy.number is not None else "")
                    + "): a program would write both corrections to one offset",
                )
                break
