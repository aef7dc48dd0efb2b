"""Fanuc and Haas: G10 programmable data input, one block per register.

Work offsets: ``G10 L2 P1…P6`` (G54…G59), Fanuc ``G10 L20 Pn`` (G54.1 Pn), Haas
``G10 L20 Pn`` (G110…G129 = P1…P20, G154 Pn = P1…P99).  Every axis of a WKS goes in
its one block (``G10 L2 P1 X… Y… Z…``).  Tool offsets (memory C): ``L10`` length
geometry, ``L11`` length wear, ``L12`` radius geometry, ``L13`` radius wear, ``P`` =
the H or D number (a radius row — component ``R`` — is a D register; the control's D
offsets must hold radii, not diameters).  With current offsets every block is absolute
(``G90``): running the program twice leaves the same values.  Without them the blocks
are incremental (``G91``) and the program guards itself against a second run: it has a
plan number (:func:`~setupfix.outputs.controllers.common.plan_number` of its text), checks
at the top that the common variable ``#549``
(:data:`~setupfix.outputs.controllers.common.GUARD_VARIABLE`) does not hold it — else it
stops with an alarm (``#3000``) before any change — and sets ``#549`` to it after the last
block (custom macro B: ``IF … THEN``, standard on the 0i-F/30i and the Haas NGC).  A WKS has no
wear offset on these controls, so ``offset = "wear"`` on a WKS is an error.

``G10 L2``/``L20`` hold no rotation: a WKS rotation row (component ``C``) with a
change is refused naming the register; one with no change is not written, and a
comment line says so (the program stays a complete instruction).

The program number is the ``O`` word: Fanuc ``O1``…``O9999``, Haas up to ``O99999``
(:data:`~setupfix.outputs.controllers.common.PROGRAM_NUMBERS`); ``O4501`` when the
caller gives none.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from setupfix.correction.offsets import OffsetRow
from setupfix.model.slots import wks_fanuc, wks_haas
from setupfix.outputs.controllers.common import (
    DEFAULT_PROGRAM,
    GUARD_VARIABLE,
    ROTATION,
    base_id,
    cannot,
    check_program_number,
    comment_text,
    groups,
    length_unit,
    number,
    one_mode,
    plan_number,
    slot_within,
    target,
    tool_letter,
)

__all__ = ["render_fanuc", "render_haas"]


def _tool(controller: str, row: OffsetRow, top: int) -> tuple[int, int]:
    letter, n = tool_letter(controller, row)
    slot_within(controller, row, "offset number", n, 1, top)
    wear = row.offset == "wear"
    return (11 if wear else 10) if letter == "H" else (13 if wear else 12), n


def _was(row: OffsetRow) -> str:
    return f"WAS {number(row, row.current or 0.0)} CHANGE {number(row, row.delta)}"


def _wks_blocks(
    controller: str,
    group: list[OffsetRow],
    mode: str,
    g: str,
    wks: Callable[[str], tuple[int, int] | None],
    wks_forms: str,
) -> list[str]:
    for row in group:
        if row.offset == "wear":
            raise cannot(controller, row, 'a work offset has no wear register here: use offset = "geometry"')
    lp = wks(group[0].register)
    if lp is None:
        raise cannot(controller, group[0], f"a work offset is {wks_forms}")
    out: list[str] = []
    moved = [r for r in group if r.axis != ROTATION]
    for row in group:
        if row.axis == ROTATION:
            if row.delta != 0.0:
                raise cannot(
                    controller,
                    row,
                    f"G10 L{lp[0]} holds no rotation (change {number(row, row.delta)} "
                    "degrees): choose a controller with frame rotation (siemens, "
                    "heidenhain) or fix the rotation in the model",
                )
            why = (
                f"{row.register} {row.id} rotation not written - G10 L{lp[0]} holds none - change "
                f"{number(row, row.delta)}"
            )
            out.append(f"({comment_text(why)})")
    if not moved:
        return out
    words = " ".join(f"{r.axis}{number(r, target(r))}" for r in moved)
    if len(moved) == 1 and moved[0].id == base_id(moved[0]) and len(group) == 1:  # a one-axis row: as always
        note = f"{moved[0].register} {moved[0].offset} {moved[0].id}" + (f" {_was(moved[0])}" if mode == "set" else "")
        return [*out, f"{g} G10 L{lp[0]} P{lp[1]} {words} ({comment_text(note)})"]
    if mode == "set":
        out += [f"({comment_text(f'{r.id} {_was(r)}')})" for r in moved]
    note = f"{moved[0].register} {moved[0].offset} {base_id(moved[0])}"
    return [*out, f"{g} G10 L{lp[0]} P{lp[1]} {words} ({comment_text(note)})"]


def _render(
    controller: str,
    rows: Sequence[OffsetRow],
    title: str,
    wks: Callable[[str], tuple[int, int] | None],
    wks_forms: str,
    tool_top: int,
    program_number: int | None,
) -> str:
    mode = one_mode(rows)
    g = "G90" if mode == "set" else "G91"
    program = check_program_number(controller, DEFAULT_PROGRAM if program_number is None else program_number)
    blocks: list[str] = []
    for group in groups(rows):
        if group[0].kind == "wks":
            blocks += _wks_blocks(controller, group, mode, g, wks, wks_forms)
            continue
        for row in group:
            g10_l, g10_p = _tool(controller, row, tool_top)
            note = f"{row.register} {row.offset} {row.id}" + (f" {_was(row)}" if mode == "set" else "")
            blocks.append(f"{g} G10 L{g10_l} P{g10_p} R{number(row, target(row))} ({comment_text(note)})")
    unit = "G21" if length_unit(rows) == "mm" else "G20"
    o_word = f"O{program:04d}"
    head = ["%", f"{o_word} ({comment_text('SETUPFIX ' + title)})" if title else f"{o_word} (SETUPFIX)"]
    if mode == "set":
        head.append("(ABSOLUTE VALUES - CURRENT PLUS CHANGE - SAFE TO RUN AGAIN)")
        return "\n".join([*head, unit, *blocks, "G90", "M30", "%"]) + "\n"
    plan = plan_number(controller, title, *blocks)  # not the O number: a plan renumbered is the same plan
    var = f"#{GUARD_VARIABLE}"
    head += [
        f"(INCREMENTAL CHANGES - RUN ONCE - PLAN {plan})",
        f"(GUARD - {var} HOLDS THE PLAN AFTER THE RUN - A SECOND RUN STOPS AT THE ALARM BELOW)",
        f"IF [{var} EQ {plan}] THEN #3000=1 (PLAN ALREADY APPLIED)",
    ]
    return "\n".join([*head, unit, *blocks, "G90", f"{var}={plan}", "M30", "%"]) + "\n"


def render_fanuc(
    rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
) -> str:
    """Fanuc M-series G10 program (0i/16i/18i/21i/30i, tool offset memory C)."""
    return _render("fanuc", rows, title, wks_fanuc, "G54…G59 or G54.1 P1…P300", 999, program_number)


def render_haas(
    rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
) -> str:
    """Haas mill G10 program."""
    return _render("haas", rows, title, wks_haas, "G54…G59, G110…G129 or G154 P1…P99", 200, program_number)
