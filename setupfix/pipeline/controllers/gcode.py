"""Fanuc and Haas: G10 programmable data input, one block per register.

Work offsets: ``G10 L2 P1…P6`` (G54…G59), Fanuc ``G10 L20 Pn`` (G54.1 Pn), Haas
``G10 L20 Pn`` (G110…G129 = P1…P20, G154 Pn = P1…P99).  Tool offsets (memory C):
``L10`` length geometry, ``L11`` length wear, ``L12`` diameter geometry, ``L13``
diameter wear, ``P`` = the H or D number.  With current offsets every block is
absolute (``G90``): running the program twice leaves the same values.  Without them
the blocks are incremental (``G91``) and the header says the program is one-shot.
A WKS has no wear offset on these controls, so ``offset = "wear"`` on a WKS is an
error.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from setupfix.offsets import OffsetRow
from setupfix.pipeline.controllers.common import cannot, comment_text, number, one_mode, target
from setupfix.model.slots import tool_hd, wks_fanuc, wks_haas

__all__ = ["render_fanuc", "render_haas"]

PROGRAM = "O4501"


def _tool(controller: str, row: OffsetRow, top: int) -> tuple[int, int]:
    found = tool_hd(row.register)
    letter, n = found if found else ("H", row.number) if row.number is not None else (None, None)
    if letter is None or n is None:
        raise cannot(controller, row, "a tool register is Hn or Dn, or give number = n in the model")
    if not 1 <= n <= top:
        raise cannot(controller, row, f"offset number {n} outside 1…{top}")
    wear = row.offset == "wear"
    return (11 if wear else 10) if letter == "H" else (13 if wear else 12), n


def _render(controller: str, rows: Sequence[OffsetRow], title: str,
            wks: Callable[[str], tuple[int, int] | None], wks_forms: str, tool_top: int) -> str:
    mode = one_mode(rows)
    blocks = []
    for row in rows:
        if row.kind == "wks":
            if row.offset == "wear":
                raise cannot(controller, row, 'a work offset has no wear register here: use offset = "geometry"')
            lp = wks(row.register)
            if lp is None:
                raise cannot(controller, row, f"a work offset is {wks_forms}")
            g10_l, g10_p = lp
            word = f"{row.axis}{number(row, target(row))}"
        else:
            g10_l, g10_p = _tool(controller, row, tool_top)
            word = f"R{number(row, target(row))}"
        note = f"{row.register} {row.offset} {row.id}"
        if mode == "set":
            note += f" WAS {number(row, row.current or 0.0)} CHANGE {number(row, row.delta)}"
        blocks.append(f"{'G90' if mode == 'set' else 'G91'} G10 L{g10_l} P{g10_p} {word} ({comment_text(note)})")
    unit = "G21" if rows and rows[0].unit == "mm" else "G20"
    head = ["%", f"{PROGRAM} ({comment_text('SETUPFIX ' + title)})" if title else f"{PROGRAM} (SETUPFIX)"]
    if mode == "set":
        head.append("(ABSOLUTE VALUES - CURRENT PLUS CHANGE - SAFE TO RUN AGAIN)")
    else:
        head.append("(INCREMENTAL CHANGES: RUN ONCE ONLY - EACH RUN ADDS THEM AGAIN)")
    return "\n".join([*head, unit, *blocks, "G90", "M30", "%"]) + "\n"


def render_fanuc(rows: Sequence[OffsetRow], title: str = "") -> str:
    """Fanuc M-series G10 program (0i/16i/18i/21i/30i, tool offset memory C)."""
    return _render("fanuc", rows, title, wks_fanuc, "G54…G59 or G54.1 P1…P300", 999)


def render_haas(rows: Sequence[OffsetRow], title: str = "") -> str:
    """Haas mill G10 program."""
    return _render("haas", rows, title, wks_haas, "G54…G59, G110…G129 or G154 P1…P99", 200)
