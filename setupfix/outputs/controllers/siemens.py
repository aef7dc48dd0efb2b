"""Siemens SINUMERIK 840D sl / 828D: a part program of system-variable assignments.

Work offsets: the settable frames ``$P_UIFR[n]`` (G500 → 0, G54…G57 → 1…4,
G505…G599 → 5…99); geometry writes the coarse translation ``TR``, wear the fine
offset ``FI``, of the row's axis (``$P_UIFR[1,X,TR]``, one assignment per axis of a
WKS).  A WKS rotation (component ``C``, degrees) is the frame's rotation about the
spindle axis, ``$P_UIFR[n,Z,RT]`` (``Z`` the model's spindle); a rotation has no fine
part, so a rotation with ``offset = "wear"`` is refused.  Tool offsets of tool T,
cutting edge D: ``$TC_DP3[T,D]`` / ``$TC_DP12[T,D]`` length 1 geometry / wear,
``$TC_DP6[T,D]`` / ``$TC_DP15[T,D]`` radius geometry / wear (component ``R``).  The
tool is named ``T5 D1`` in the model, or given by ``number`` (T) and ``edge`` (D).
With current offsets the assignments are absolute; without them they read
``x = x + change`` and the program guards itself against a second run: it checks at the
top that the R parameter ``R99`` (:data:`~setupfix.outputs.controllers.common.GUARD_R`)
does not hold its plan number (else it jumps past every change to a message and ``M0``),
and sets ``R99`` to it after the last change.  A changed frame
takes effect when it is next selected (G54…), which the program does not do.

With a program number the text begins in the punched-tape form that names the program
on loading: ``%_N_SETUPFIX_<n>_MPF`` and ``;$PATH=/_N_MPF_DIR`` (part programs); without
one it has no name line (the file name names it).
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.correction.offsets import OffsetRow
from setupfix.model.slots import tool_edge, wks_siemens
from setupfix.outputs.controllers.common import (
    GUARD_R,
    RADIUS,
    ROTATION,
    cannot,
    check_program_number,
    length_unit,
    number,
    one_mode,
    plan_number,
    slot_within,
    target,
)

__all__ = ["render", "program_name", "TOOLS", "EDGES", "DONE_LABEL"]

#: The label a second run of an incremental program jumps to (past every change).
DONE_LABEL = "SETUPFIX_APPLIED"

#: Highest tool number T and cutting edge D an 840D sl addresses (T0 is no tool, D0 no offset: 1…32000 each).
TOOLS, EDGES = 32000, 32000


def program_name(n: int) -> str:
    """The part program's name for program number ``n`` (letters first, at most 24 characters)."""
    return f"SETUPFIX_{n}"


def _variable(row: OffsetRow, spindle: str) -> str:
    if row.kind == "wks":
        n = wks_siemens(row.register)
        if n is None:
            raise cannot("siemens", row, "a work offset is G500, G54…G57 or G505…G599")
        if row.axis == ROTATION:
            if row.offset == "wear":
                raise cannot("siemens", row, 'a frame rotation has no fine offset: use offset = "geometry"')
            return f"$P_UIFR[{n},{spindle},RT]"
        return f"$P_UIFR[{n},{row.axis},{'FI' if row.offset == 'wear' else 'TR'}]"
    found = tool_edge(row.register)
    t, d = found if found else (row.number, None)
    d = d if d is not None else row.edge
    if t is None or d is None:
        raise cannot("siemens", row, "a tool is named T5 D1, or give number = T and edge = D in the model")
    slot_within("siemens", row, "tool number T", t, 1, TOOLS)  # T0 is "no tool"
    slot_within("siemens", row, "cutting edge D", d, 1, EDGES)  # D0 is "no offset"
    wear = row.offset == "wear"
    if row.axis == RADIUS:
        return f"$TC_DP{15 if wear else 6}[{t},{d}]"
    return f"$TC_DP{12 if wear else 3}[{t},{d}]"


def render(rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z") -> str:
    mode = one_mode(rows)
    unit = length_unit(rows)
    lines = []
    if program_number is not None:
        lines += [f"%_N_{program_name(check_program_number('siemens', program_number))}_MPF", ";$PATH=/_N_MPF_DIR"]
    lines += [f"; SETUPFIX {title}".rstrip(), f"; values in {unit}"]
    if any(r.axis == ROTATION for r in rows):
        lines.append("; rotations (RT) in degrees")
    body: list[str] = []
    for row in rows:
        var = _variable(row, spindle)
        if mode == "set":
            body.append(
                f"{var}={number(row, target(row))} ; {row.id} {row.register} {row.offset} was "
                f"{number(row, row.current or 0.0)} change {number(row, row.delta)}"
            )
        else:
            body.append(f"{var}={var}{number(row, row.delta)} ; {row.id} {row.register} {row.offset}")
    if mode == "set":
        lines.append("; absolute values = current + change: safe to run again")
        return "\n".join([*lines, *body, "M30"]) + "\n"
    plan = plan_number("siemens", title, *body)  # not the program name: a plan renumbered is the same plan
    lines += [
        f"; incremental changes - run once - plan {plan}",
        f"; guard: {GUARD_R} holds the plan after the run - a second run stops at the message below",
        f"IF {GUARD_R}=={plan} GOTOF {DONE_LABEL}",
    ]
    tail = [f"{GUARD_R}={plan}", "M30", f"{DONE_LABEL}:", f'MSG("SETUPFIX PLAN {plan} ALREADY APPLIED")', "M0", "M30"]
    return "\n".join([*lines, *body, *tail]) + "\n"
