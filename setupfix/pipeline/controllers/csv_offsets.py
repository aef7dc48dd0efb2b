"""The offsets CSV (``../shared/spec/cli-json.md``): the spec's columns first, then offset, current, value."""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from typing import TextIO

from setupfix.offsets import OFFSET_COLUMNS, OffsetRow

__all__ = ["render", "write_header", "write_rows"]


def write_header(stream: TextIO) -> None:
    csv.writer(stream, lineterminator="\n").writerow(OFFSET_COLUMNS)


def write_rows(stream: TextIO, rows: Iterable[OffsetRow]) -> None:
    """Append rows (batch streams them report by report)."""
    writer = csv.writer(stream, lineterminator="\n")
    for r in rows:
        writer.writerow(r.cells())


def render(rows: Sequence[OffsetRow], title: str = "") -> str:
    out = io.StringIO()
    write_header(out)
    write_rows(out, rows)
    return out.getvalue()
