"""Siemens SINUMERIK 840D sl / 828D: a part program of system-variable assignments.

Work offsets: the settable frames ``$P_UIFR[n]`` (G500 → 0, G54…G57 → 1…4,
G505…G599 → 5…99); geometry writes the coarse translation ``TR``, wear the fine
offset ``FI``.  Tool offsets of tool T, cutting edge D: ``$TC_DP3[T,D]`` length 1
geometry, ``$TC_DP12[T,D]`` length 1 wear.  The tool is named ``T5 D1`` in the
model, or given by ``number`` (T) and ``edge`` (D).  With current offsets the
assignments are absolute; without them they read ``x = x + change`` and the header
says the program is one-shot.  A changed frame takes effect when it is next
selected (G54…), which the program does not do.
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.offsets import OffsetRow
from setupfix.pipeline.controllers.common import cannot, number, one_mode, target
from setupfix.model.slots import tool_edge, wks_siemens

__all__ = ["render"]


def _variable(row: OffsetRow) -> str:
    if row.kind == "wks":
        n = wks_siemens(row.register)
        if n is None:
            raise cannot("siemens", row, "a work offset is G500, G54…G57 or G505…G599")
        return f"$P_UIFR[{n},{row.axis},{'FI' if row.offset == 'wear' else 'TR'}]"
    found = tool_edge(row.register)
    t, d = found if found else (row.number, None)
    d = d if d is not None else row.edge
    if t is None or d is None:
        raise cannot("siemens", row, "a tool is named T5 D1, or give number = T and edge = D in the model")
    return f"$TC_DP{12 if row.offset == 'wear' else 3}[{t},{d}]"


def render(rows: Sequence[OffsetRow], title: str = "") -> str:
    mode = one_mode(rows)
    unit = rows[0].unit if rows else "mm"
    lines = [f"; SETUPFIX {title}".rstrip(), f"; values in {unit}"]
    if mode == "set":
        lines.append("; absolute values = current + change: safe to run again")
    else:
        lines.append("; incremental changes: run once only - each run adds them again")
    for row in rows:
        var = _variable(row)
        if mode == "set":
            lines.append(f"{var}={number(row, target(row))} ; {row.id} {row.register} {row.offset} was "
                         f"{number(row, row.current or 0.0)} change {number(row, row.delta)}")
        else:
            lines.append(f"{var}={var}{number(row, row.delta)} ; {row.id} {row.register} {row.offset}")
    lines.append("M30")
    return "\n".join(lines) + "\n"
