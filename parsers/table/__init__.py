"""Shop CSV / Excel tables with a column mapping (registered as ``table``)."""

from __future__ import annotations

from parsers.registry import FormatSpec, register
from parsers.source import final_line_break
from parsers.table.mapping import KEYS, guess_columns, parse_columns
from parsers.table.reader import load_grid, read_table, sniff_table

__all__ = ["KEYS", "guess_columns", "load_grid", "parse_columns", "read_table", "sniff_table", "SPEC"]


def _table_complete(data: bytes) -> str | None:
    """A workbook is a zip (its reader refuses a cut one); delimited text ends with a line break."""
    return None if data[:2] == b"PK" else final_line_break(data)


SPEC = register(
    FormatSpec(
        name="table",
        description="shop CSV/TSV or Excel .xlsx table; columns mapped with --columns KEY=HEADER,... or guessed",
        extensions=(".xlsx", ".xlsm", ".csv", ".tsv"),
        sniff=lambda peek: sniff_table(peek.head, peek.text),
        read=read_table,
        options=("unit", "encoding", "columns"),
        priority=5,
        complete=_table_complete,
    )
)
