"""Shop CSV / Excel tables with a column mapping (registered as ``table``)."""

from __future__ import annotations

from parsers._registry import FormatSpec, register
from parsers.table.mapping import KEYS, guess_columns, parse_columns
from parsers.table.reader import load_grid, read_table, sniff_table

__all__ = ["KEYS", "guess_columns", "load_grid", "parse_columns", "read_table", "sniff_table", "SPEC"]

SPEC = register(FormatSpec(
    name="table",
    description="shop CSV/TSV or Excel .xlsx table; columns mapped with --columns KEY=HEADER,... or guessed",
    extensions=(".xlsx", ".xlsm", ".csv", ".tsv"),
    sniff=lambda peek: sniff_table(peek.head, peek.text),
    read=read_table,
    options=("unit", "encoding", "columns"),
    priority=5,
))
