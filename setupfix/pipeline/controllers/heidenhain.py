"""HEIDENHAIN TNC: values for the preset table and the tool table.

A TNC table holds absolute values, so this format needs the current offsets
(``--current``).  WKS rows go to the preset table (``PRESET.PR``, row ``NO`` =
``number`` in the model, or the digits of a register named ``PRESET 3``), column of
the model axis; tool rows to the tool table (``TOOL.T``, row ``T`` = ``number`` or
the T of ``T5``), column ``L`` (geometry) or ``DL`` (wear).  Each table is written as
``BEGIN … MM`` / header / rows / ``[END]`` with only the columns changed, to merge
into the control's table (TNCremo, table editor).
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.errors import ExportError
from setupfix.model.slots import preset_row, tool_edge
from setupfix.offsets import OffsetRow
from setupfix.pipeline.controllers.common import cannot, number, one_mode, target

__all__ = ["render"]

def _table(name: str, unit: str, columns: tuple[str, str], rows: list[tuple[str, str]]) -> list[str]:
    w0 = max(len(columns[0]), *(len(r[0]) for r in rows)) + 2
    w1 = max(len(columns[1]), *(len(r[1]) for r in rows)) + 2
    lines = [f"BEGIN {name} {'MM' if unit == 'mm' else 'INCH'}", f"{columns[0]:<{w0}}{columns[1]:<{w1}}".rstrip()]
    lines += [f"{a:<{w0}}{b:<{w1}}".rstrip() for a, b in rows]
    return [*lines, "[END]"]


def render(rows: Sequence[OffsetRow], title: str = "") -> str:
    if rows and one_mode(rows) != "set":
        raise ExportError("heidenhain: the preset and tool tables hold absolute values: give the current "
                          "offsets (--current FILE)")
    presets: list[tuple[str, str]] = []
    tools: dict[str, list[tuple[str, str]]] = {"L": [], "DL": []}
    axis = rows[0].axis if rows else "Z"
    for row in rows:
        if row.kind == "wks":
            if row.offset == "wear":
                raise cannot("heidenhain", row, 'the preset table has no wear column: use offset = "geometry"')
            n = row.number if row.number is not None else preset_row(row.register)
            if n is None:
                raise cannot("heidenhain", row, "give the preset row: number = n in the model (or name it PRESET n)")
            presets.append((str(n), number(row, target(row))))
        else:
            found = tool_edge(row.register)
            t = row.number if row.number is not None else (found[0] if found else None)
            if t is None:
                raise cannot("heidenhain", row, "give the tool number: number = n in the model (or name it Tn)")
            tools["DL" if row.offset == "wear" else "L"].append((str(t), number(row, target(row))))
    for table, entries in (("preset", presets), *(("tool " + c, v) for c, v in tools.items())):
        seen = [n for n, _ in entries]
        twice = sorted({n for n in seen if seen.count(n) > 1})
        if twice:  # two edges of one tool (T5 D1, T5 D2): the tool table has one row per tool
            raise ExportError(f"heidenhain: two registers write {table} row {twice[0]}; the table holds one "
                              "value per row (give each register its own number)")
    unit = rows[0].unit if rows else "mm"
    out: list[str] = []
    if presets:
        out += _table("PRESET.PR", unit, ("NO", axis), presets)
    for column, values in tools.items():
        if values:
            out += _table("TOOL.T", unit, ("T", column), values)
    return "\n".join(out) + "\n"
