"""Controller slots derived from register names (G54, G54.1P7, G154 P12, H5, T5 D1, …).

Each function returns the slot or ``None`` when the name does not have that form;
the renderers turn ``None`` into an error naming the register.
"""

from __future__ import annotations

import re

__all__ = ["wks_fanuc", "wks_haas", "wks_siemens", "tool_hd", "tool_edge"]

_G = re.compile(r"^G(\d+)(?:\.(\d))?\s*(?:P\s*(\d+))?$", re.IGNORECASE)
_HD = re.compile(r"^([HD])\s*(\d+)$", re.IGNORECASE)
_TD = re.compile(r"^T\s*(\d+)(?:\s*D\s*(\d+))?$", re.IGNORECASE)


def _g(name: str) -> tuple[int, int | None, int | None] | None:
    m = _G.match(name.strip())
    if not m:
        return None
    second, third = m.group(2), m.group(3)
    return int(m.group(1)), None if second is None else int(second), None if third is None else int(third)


def wks_fanuc(name: str) -> tuple[int, int] | None:
    """(L, P): G54…G59 → L2 P1…P6; G54.1 Pn → L20 Pn (n = 1…300)."""
    g = _g(name)
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
    g = _g(name)
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
    g = _g(name)
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
