"""Controller slots of registers: what a controller program addresses for a register name.

The one reading of register names (``G54``, ``G54.1 P7``, ``G154 P12``, ``G110``,
``H05``, ``T5 D1``, ``PRESET 3``) and of the model's explicit ``number`` / ``edge``.
The controller renderers (:mod:`setupfix.outputs.controllers`) turn a slot into
their program words with the per-controller functions below; the loader calls
:func:`register_slots` to refuse a model whose registers share a slot.

Slots, by the program word a controller writes (see the module texts of the renderers):

============================  ==========================================================
register                      slots
============================  ==========================================================
``G54`` … ``G59``             ``G54`` … ``G59`` (Fanuc/Haas ``G10 L2 P1…P6``, Siemens frame 1…4)
``G54.1 Pn`` (``G54.1Pn``,    ``G54.1 Pn`` (Fanuc ``G10 L20 Pn``); Haas ``G110`` … ``G129`` and
``G54.1 P0n``)                ``G154 Pn`` are the same extended offsets (``G10 L20 Pn``)
``G500``, ``G505`` … ``G599`` ``G500`` … (Siemens settable frames 0, 5…99)
``Hn`` / ``Dn``               ``Hn`` / ``Dn`` (Fanuc/Haas offset number n, leading zeros dropped)
``Tn Dm``                     ``Tn Dm`` (Siemens tool T, cutting edge D)
``Tn`` (no edge)              ``Tn`` (HEIDENHAIN tool-table row)
``PRESET n`` / ``PR n``       ``PRESET n`` (HEIDENHAIN preset-table row)
``number = n`` (WKS)          ``PRESET n`` (the row HEIDENHAIN writes)
``number = n`` (tool)         ``Hn`` where the name is not Hn/Dn (Fanuc/Haas), ``Tn`` (HEIDENHAIN),
                              ``Tn Dm`` with ``edge = m`` where the name is not Tn (Siemens)
any other name                the name itself, case and blanks folded
============================  ==========================================================

A tool ``T5 D1`` and ``T5 D2`` are two edges of one Siemens tool, not a collision; the
HEIDENHAIN tool table has no edges, so its renderer refuses two rows of one tool.
"""

from __future__ import annotations

import re

__all__ = ["g_code", "wks_fanuc", "wks_haas", "wks_siemens", "tool_hd", "tool_edge", "preset_row", "register_slots"]

_G = re.compile(r"^G\s*(\d+)(?:\.(\d))?\s*(?:P\s*(\d+))?$", re.IGNORECASE)
_HD = re.compile(r"^([HD])\s*(\d+)$", re.IGNORECASE)
_TD = re.compile(r"^T\s*(\d+)(?:\s*D\s*(\d+))?$", re.IGNORECASE)
_PRESET = re.compile(r"^(?:PRESET|PR)\s*#?\s*(\d+)$", re.IGNORECASE)
_SPACES = re.compile(r"\s+")


def g_code(name: str) -> tuple[int, int | None, int | None] | None:
    """(code, sub, P) of a G-code register name: ``G54.1 P07`` → (54, 1, 7); None for other names."""
    m = _G.match(name.strip())
    if not m:
        return None
    second, third = m.group(2), m.group(3)
    return int(m.group(1)), None if second is None else int(second), None if third is None else int(third)


def wks_fanuc(name: str) -> tuple[int, int] | None:
    """(L, P): G54…G59 → L2 P1…P6; G54.1 Pn → L20 Pn (n = 1…300)."""
    g = g_code(name)
    if g is None:
        return None
    code, sub, p = g
    if sub is None and p is None and 54 <= code <= 59:
        return 2, code - 53
    if code == 54 and sub == 1 and p is not None and 1 <= p <= 300:
        return 20, p
    return None


def wks_haas(name: str) -> tuple[int, int] | None:
    """(L, P): G54…G59 → L2 P1…P6; G110…G129 → L20 P1…P20; G154 Pn → L20 Pn (n = 1…99)."""
    g = g_code(name)
    if g is None:
        return None
    code, sub, p = g
    if sub is not None:
        return None
    if p is None and 54 <= code <= 59:
        return 2, code - 53
    if p is None and 110 <= code <= 129:
        return 20, code - 109
    if code == 154 and p is not None and 1 <= p <= 99:
        return 20, p
    return None


def wks_siemens(name: str) -> int | None:
    """Settable frame index of $P_UIFR: G500 → 0, G54…G57 → 1…4, G505…G599 → 5…99."""
    g = g_code(name)
    if g is None or g[1] is not None or g[2] is not None:
        return None
    code = g[0]
    if code == 500:
        return 0
    if 54 <= code <= 57:
        return code - 53
    if 505 <= code <= 599:
        return code - 500
    return None


def tool_hd(name: str) -> tuple[str, int] | None:
    """("H" | "D", n) of a Fanuc/Haas length or diameter register name."""
    m = _HD.match(name.strip())
    return (m.group(1).upper(), int(m.group(2))) if m else None


def tool_edge(name: str) -> tuple[int, int | None] | None:
    """(T, D) of a Siemens/Heidenhain tool name ``T5 D1`` / ``T5`` (D None)."""
    m = _TD.match(name.strip())
    return (int(m.group(1)), None if m.group(2) is None else int(m.group(2))) if m else None


def preset_row(name: str) -> int | None:
    """Row of the HEIDENHAIN preset table named by ``PRESET 3`` / ``PR 3`` / ``PRESET #3``."""
    m = _PRESET.match(name.strip())
    return int(m.group(1)) if m else None


def _wks_name_slot(name: str) -> str | None:
    g = g_code(name)
    if g is None:
        row = preset_row(name)
        return None if row is None else f"PRESET {row}"
    code, sub, p = g
    if sub is None and p is None and 110 <= code <= 129:
        return f"G54.1 P{code - 109}"  # Haas G110…G129 = G154 P1…P20 = the extended offsets P1…P20
    if (code, sub) == (154, None) and p is not None:
        return f"G54.1 P{p}"
    return f"G{code}" + ("" if sub is None else f".{sub}") + ("" if p is None else f" P{p}")


def register_slots(kind: str, name: str, number: int | None = None, edge: int | None = None) -> frozenset[str]:
    """Canonical names of the controller slots a register addresses (see the module table).

    Two registers of a model must not share one: a program would write both
    corrections to one offset.

    Parameters
    ----------
    kind : {"wks", "tool"}
    name : str
        The controller register name of the model (``register = "…"``).
    number, edge : int, optional
        The model's explicit ``number`` and ``edge`` of the register.
    """
    slots: set[str] = set()
    if kind == "wks":
        named = _wks_name_slot(name)
        if named is not None and not (number is not None and named.startswith("PRESET")):
            slots.add(named)
        if number is not None:
            slots.add(f"PRESET {number}")
    else:
        hd, te = tool_hd(name), tool_edge(name)
        gcode = hd if hd is not None else ("H", number) if number is not None else None  # Fanuc, Haas
        if gcode is not None:
            slots.add(f"{gcode[0]}{gcode[1]}")
        t, d = te if te is not None else (number, None)  # Siemens: tool T, edge D
        d = d if d is not None else edge
        if t is not None and d is not None:
            slots.add(f"T{t} D{d}")
        row = number if number is not None else te[0] if te is not None else None  # HEIDENHAIN tool row
        if row is not None and d is None:
            slots.add(f"T{row}")
    if not slots:
        slots.add(_SPACES.sub(" ", name.strip()).upper())
    return frozenset(slots)
