"""HEIDENHAIN TNC: values for the preset table and the tool table.

A TNC table holds absolute values, so this format needs the current offsets
(``--current``).  WKS rows go to the preset table (``PRESET.PR``, row ``NO`` =
``number`` in the model, or the digits of a register named ``PRESET 3``), one column
per axis of the WKS (``X``, ``Y``, ``Z``) and its rotation about the tool axis
(component ``C``, degrees) in ``SPC`` — the basic rotation's column on the TNC 640
and TNC7 (an iTNC 530 keeps it in ``ROT``: rename the column there).  Tool rows go to
the tool table (``TOOL.T``, row ``T`` = ``number`` or the T of ``T5``): length in
``L`` (geometry) or ``DL`` (wear), radius (component ``R``) in ``R`` or ``DR``.  Each
table is written as ``BEGIN … MM`` / header / rows / ``[END]`` with only the columns
changed, to merge into the control's table (TNCremo, table editor): one ``PRESET.PR`` table
with one row per preset and one ``TOOL.T`` table with one row per tool, each holding the
columns any of its rows changes; a cell a row does not change (a tool without a radius
register in a table that has ``R``) is left blank — keep the control's value there.  The
tables have no program name: a program number is not written.
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.core.errors import ExportError
from setupfix.correction.offsets import OffsetRow
from setupfix.model.slots import preset_row, tool_edge
from setupfix.outputs.controllers.common import (
    RADIUS,
    ROTATION,
    cannot,
    groups,
    length_unit,
    number,
    one_mode,
    slot_within,
    target,
)

__all__ = ["render", "PRESET_COLUMNS", "TOOL_COLUMNS", "PRESETS", "TOOLS"]

#: Rows a TNC addresses: preset rows 1…99,999,999 (row 0 keeps the preset set by hand, the control's own),
#: tools 1…32,767 (T0 is the zero tool).
PRESETS, TOOLS = 99_999_999, 32_767

#: Tool-table columns written, in table order: length geometry and wear, radius geometry and wear.
TOOL_COLUMNS = ("L", "DL", "R", "DR")
#: Preset-table column of each WKS component.
PRESET_COLUMNS = {"X": "X", "Y": "Y", "Z": "Z", ROTATION: "SPC"}


def _table(name: str, unit: str, columns: tuple[str, ...], rows: Sequence[tuple[str, ...]]) -> list[str]:
    widths = [max(len(c), *(len(r[i]) for r in rows)) + 2 for i, c in enumerate(columns)]

    def line(cells: tuple[str, ...]) -> str:
        return "".join(f"{c:<{w}}" for c, w in zip(cells, widths, strict=True)).rstrip()

    return [f"BEGIN {name} {'MM' if unit == 'mm' else 'INCH'}", line(columns), *(line(r) for r in rows), "[END]"]


def _twice(table: str, seen: list[str]) -> None:
    twice = sorted({n for n in seen if seen.count(n) > 1})
    if twice:  # two edges of one tool (T5 D1, T5 D2): the tool table has one row per tool
        raise ExportError(
            f"heidenhain: two registers write {table} row {twice[0]}; the table holds one "
            "value per row (give each register its own number)"
        )


def render(rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z") -> str:
    if rows and one_mode(rows) != "set":
        raise ExportError(
            "heidenhain: the preset and tool tables hold absolute values: give the current offsets (--current FILE)"
        )
    presets: dict[str, dict[str, str]] = {}  # NO → column → value: one table row per preset
    preset_columns: dict[str, list[str]] = {}  # the columns written, for the twice-check
    tools: dict[str, list[tuple[str, str]]] = {c: [] for c in TOOL_COLUMNS}  # column → (T, value)
    by_tool: dict[str, dict[str, str]] = {}  # T → column → value: one table row per tool, in model order
    for group in groups(rows):
        if group[0].kind == "wks":
            for row in group:
                if row.offset == "wear":
                    raise cannot("heidenhain", row, 'the preset table has no wear column: use offset = "geometry"')
            row = group[0]
            n = row.number if row.number is not None else preset_row(row.register)
            if n is None:
                raise cannot("heidenhain", row, "give the preset row: number = n in the model (or name it PRESET n)")
            slot_within("heidenhain", row, "preset row", n, 1, PRESETS)  # row 0: the control's manual preset
            for r in group:
                column = PRESET_COLUMNS.get(r.axis, r.axis)
                preset_columns.setdefault(column, []).append(str(n))
                presets.setdefault(str(n), {})[column] = number(r, target(r))
            continue
        for row in group:
            found = tool_edge(row.register)
            t = row.number if row.number is not None else (found[0] if found else None)
            if t is None:
                raise cannot("heidenhain", row, "give the tool number: number = n in the model (or name it Tn)")
            slot_within("heidenhain", row, "tool number", t, 1, TOOLS)  # T0: the zero tool (L = R = 0)
            wear = row.offset == "wear"
            column = ("DR" if wear else "R") if row.axis == RADIUS else ("DL" if wear else "L")
            tools[column].append((str(t), number(row, target(row))))
            by_tool.setdefault(str(t), {})[column] = tools[column][-1][1]
    for column, seen in preset_columns.items():
        _twice("preset" if len(preset_columns) == 1 else f"preset {column}", seen)
    for column, values in tools.items():
        _twice("tool " + column, [n for n, _ in values])
    unit = length_unit(rows)
    out: list[str] = []
    if presets:
        order = [*PRESET_COLUMNS.values()]
        columns = sorted(preset_columns, key=lambda c: (order.index(c) if c in order else len(order), c))
        out += _table("PRESET.PR", unit, ("NO", *columns), _cells(presets, columns))
    if by_tool:
        columns = [c for c in TOOL_COLUMNS if tools[c]]
        out += _table("TOOL.T", unit, ("T", *columns), _cells(by_tool, columns))
    return "\n".join(out) + "\n"


def _cells(table: dict[str, dict[str, str]], columns: Sequence[str]) -> list[tuple[str, ...]]:
    """Rows of one table: the key, then each column's value, blank where the row's value is not changed."""
    return [(key, *(cells.get(c, "") for c in columns)) for key, cells in table.items()]
