"""Fanuc and Haas custom macro B: offsets written to their system variables, for controls or shops without G10.

One assignment per register component, ``#5221=[#5221+0.012]`` (add) or ``#5221=-250.111`` (set).
The variable numbers (facts from the controls' macro variable tables; sources in
``docs/howto/controllers.md``, *Macro variables*):

Fanuc M series (0i-D/F, 16i/18i/21i, 30i; tool offset memory C), axis k = 1, 2, 3 for X, Y, Z
(the control's axis order: a machine whose first three controlled axes are not X, Y, Z must not
use this output):

- work offsets G54…G59: ``#5221 + 20·(n−1) + (k−1)``, n = 1…6;
- G54.1 P1…P48: ``#7001 + 20·(p−1) + (k−1)``; P49…P300: ``#14001 + 20·(p−1) + (k−1)``;
- tool length H n: wear ``#2000 + n``, geometry ``#2200 + n`` (n ≤ 200); wear ``#10000 + n``,
  geometry ``#11000 + n`` (n ≤ 999);
- tool radius D n: wear ``#12000 + n``, geometry ``#13000 + n`` (n ≤ 999).

Haas mill (NGC and classic; variables differ from Fanuc's: ``#2001`` is a Haas length *geometry*):

- G54…G59 as Fanuc; G110…G129 (= G154 P1…P20): ``#7001 + 20·(m−1) + (k−1)``; G154 P21…P99 are
  refused (their variable map is not verified here);
- tool length H n (n ≤ 200): geometry ``#2000 + n``, wear ``#2200 + n``;
- a tool radius is refused: the Haas D variables hold diameters or radii as the control's settings
  say, which a program cannot know.

Add rows give an incremental program guarded like the G10 one (a plan number in ``#549``, an alarm
``#3000`` on a second run); set rows give absolute values, safe to run again.  No variable holds a
WKS rotation: a rotation row with a change is refused, one without a change is a comment.  The
values are in the program's unit (``G20``/``G21`` at the top, as in the G10 programs).
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.core.errors import ExportError
from setupfix.correction.offsets import OffsetRow
from setupfix.model.slots import g_code
from setupfix.outputs.controllers.common import (
    DEFAULT_PROGRAM,
    GUARD_VARIABLE,
    ROTATION,
    cannot,
    check_program_number,
    comment_text,
    length_unit,
    number,
    one_mode,
    plan_number,
    slot_within,
    target,
    tool_letter,
)

__all__ = ["AXIS_NUMBER", "fanuc_variable", "haas_variable", "render_fanuc_macro", "render_haas_macro"]

#: Axis word → its place k − 1 among the controlled axes (X, Y, Z the first three).
AXIS_NUMBER = {"X": 0, "Y": 1, "Z": 2}


def _axis(controller: str, row: OffsetRow) -> int:
    k = AXIS_NUMBER.get(row.axis.upper())
    if k is None:
        raise cannot(controller, row, f"axis {row.axis!r}: only X, Y and Z have a work offset variable here")
    return k


def _work(controller: str, row: OffsetRow) -> int:
    """The work offset variable of a WKS translation row."""
    if row.offset == "wear":
        raise cannot(controller, row, 'a work offset has no wear variable here: use offset = "geometry"')
    g = g_code(row.register)
    k = _axis(controller, row)
    if g is not None:
        code, sub, p = g
        if sub is None and p is None and 54 <= code <= 59:
            return 5221 + 20 * (code - 54) + k
        if controller == "fanuc-macro" and code == 54 and sub == 1 and p is not None:
            slot_within(controller, row, "G54.1 P", p, 1, 300)
            return (7001 if p <= 48 else 14001) + 20 * (p - 1) + k
        if controller == "haas-macro" and sub is None and p is None and 110 <= code <= 129:
            return 7001 + 20 * (code - 110) + k
        if controller == "haas-macro" and code == 154 and sub is None and p is not None:
            slot_within(controller, row, "G154 P (variables #7001… verified for P1…P20)", p, 1, 20)
            return 7001 + 20 * (p - 1) + k
    forms = "G54…G59 or G54.1 P1…P300" if controller == "fanuc-macro" else "G54…G59, G110…G129 or G154 P1…P20"
    raise cannot(controller, row, f"a work offset is {forms}")


def _tool(controller: str, row: OffsetRow) -> int:
    """The tool offset variable of a length (H) or radius (D) row."""
    letter, n = tool_letter(controller, row)
    wear = row.offset == "wear"
    if controller == "haas-macro":
        if letter == "D":
            raise cannot(
                controller,
                row,
                "the Haas D variables (#2401…) hold a diameter or a radius as the control's settings say: "
                "use the haas (G10) output or a CSV",
            )
        slot_within(controller, row, "offset number", n, 1, 200)
        return (2200 if wear else 2000) + n
    slot_within(controller, row, "offset number", n, 1, 999)
    if letter == "D":
        return (12000 if wear else 13000) + n
    if n <= 200:
        return (2000 if wear else 2200) + n
    return (10000 if wear else 11000) + n


def fanuc_variable(row: OffsetRow) -> int:
    """The Fanuc system variable of a register component (see the module text).

    Raises
    ------
    ExportError
        A register or component without one.
    """
    return _tool("fanuc-macro", row) if row.kind != "wks" else _work("fanuc-macro", row)


def haas_variable(row: OffsetRow) -> int:
    """The Haas mill macro variable of a register component (see the module text).

    Raises
    ------
    ExportError
        A register or component without one.
    """
    return _tool("haas-macro", row) if row.kind != "wks" else _work("haas-macro", row)


def _render(controller: str, rows: Sequence[OffsetRow], title: str, program_number: int | None) -> str:
    mode = one_mode(rows)
    program = check_program_number(controller, DEFAULT_PROGRAM if program_number is None else program_number)
    variable = fanuc_variable if controller == "fanuc-macro" else haas_variable
    blocks: list[str] = []
    used: dict[int, OffsetRow] = {}
    for row in rows:
        if row.kind == "wks" and row.axis == ROTATION:
            if row.delta != 0.0:
                raise cannot(
                    controller,
                    row,
                    f"no macro variable holds a work offset rotation (change {number(row, row.delta)} degrees): "
                    "choose a controller with frame rotation (siemens, heidenhain) or fix the rotation in the model",
                )
            blocks.append(f"({comment_text(f'{row.register} {row.id} rotation not written - no variable holds it')})")
            continue
        var = variable(row)
        if var in used:
            raise ExportError(
                f"{controller}: registers {used[var].register!r} ({used[var].id}) and {row.register!r} ({row.id}) "
                f"both write #{var}"
            )
        used[var] = row
        note = f"{row.register} {row.offset} {row.id}"
        if mode == "set":
            was = f" WAS {number(row, row.current or 0.0)} CHANGE {number(row, row.delta)}"
            blocks.append(f"#{var}={number(row, target(row)).lstrip('+')} ({comment_text(note + was)})")
        else:
            blocks.append(f"#{var}=[#{var}{number(row, row.delta)}] ({comment_text(note)})")
    unit = "G21" if length_unit(rows) == "mm" else "G20"
    o_word = f"O{program:04d}"
    head = ["%", f"{o_word} ({comment_text('SETUPFIX ' + title)})" if title else f"{o_word} (SETUPFIX)"]
    if mode == "set":
        head.append("(ABSOLUTE VALUES IN MACRO VARIABLES - CURRENT PLUS CHANGE - SAFE TO RUN AGAIN)")
        return "\n".join([*head, unit, *blocks, "M30", "%"]) + "\n"
    plan = plan_number(controller, title, *blocks)
    guard = f"#{GUARD_VARIABLE}"
    head += [
        f"(INCREMENTAL CHANGES IN MACRO VARIABLES - RUN ONCE - PLAN {plan})",
        f"(GUARD - {guard} HOLDS THE PLAN AFTER THE RUN - A SECOND RUN STOPS AT THE ALARM BELOW)",
        f"IF [{guard} EQ {plan}] THEN #3000=1 (PLAN ALREADY APPLIED)",
    ]
    return "\n".join([*head, unit, *blocks, f"{guard}={plan}", "M30", "%"]) + "\n"


def render_fanuc_macro(
    rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
) -> str:
    """Fanuc M-series custom macro B program writing the offsets' system variables (memory C)."""
    return _render("fanuc-macro", rows, title, program_number)


def render_haas_macro(
    rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
) -> str:
    """Haas mill macro program writing the offsets' macro variables."""
    return _render("haas-macro", rows, title, program_number)
