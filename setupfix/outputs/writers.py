"""Every result file setupfix writes, in one place (layer 4: the engine writes no files).

The primitives come from :mod:`setupfix.core.atomic`: :func:`check_target` (``-`` for
standard output or a regular file, new or existing; a folder, device, FIFO, socket
or symbolic link is refused with an :class:`~setupfix.core.errors.ExportError` naming
it), :func:`write_text` and :func:`write_bytes` (atomic: complete or absent).
Commands call :func:`check_target` on every output before any work, so a bad
target costs nothing.

The format writers below turn a result into bytes and hand them to those
primitives; each has a write → read round trip test.

Every text cell of every CSV setupfix writes (the offsets CSV of ``correct``,
``batch`` and the TUI's export, the canonical tables of ``parse``) goes through the
one function :func:`csv_cell`: a name that is not UTF-8 or holds a control
character is written with visible escapes (``\\xff``, ``\\r``; never a crash, never a
line break inside a row), and a cell a spreadsheet would run as a formula
(``= + - @``, tab, CR first) is prefixed with ``'``, which
:func:`parsers.canonical.read_canonical` removes again.  Numbers are never touched.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable
from typing import TYPE_CHECKING

import pandas as pd

from parsers.names import visible_name
from setupfix.core.atomic import atomic_write, check_target, write_bytes, write_text
from setupfix.correction.offsets import OFFSET_COLUMNS, OffsetRow

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "check_target",
    "write_text",
    "write_bytes",
    "atomic_write",
    "write_offsets_csv",
    "offsets_csv_text",
    "csv_header",
    "csv_lines",
    "csv_cell",
    "write_canonical_csv",
    "escape_formulas",
    "write_figure",
    "write_table_csv",
    "FLOAT_FORMAT",
    "FORMULA_START",
    "ROTATION_UNIT",
]

Target = str | os.PathLike[str]

#: Lengths are written with 12 significant digits: exact for every report value
#: (≤ 7 decimals in the samples) and free of binary noise in actual − nominal.
FLOAT_FORMAT = "%.12g"


#: First characters that make a spreadsheet read a cell as a formula (``=HYPERLINK(…)``, ``@SUM``, …).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")

#: Columns of the offsets CSV that hold text (names from the report and the model); the others are numbers.
_OFFSET_TEXT = frozenset({"report", "part", "id", "register", "kind", "axis", "unit", "mode", "offset", "verdict"})
_TEXT_AT = tuple(i for i, name in enumerate(OFFSET_COLUMNS) if name in _OFFSET_TEXT)
_UNIT_AT = OFFSET_COLUMNS.index("unit")

#: The ``unit`` cell of a WKS rotation row (component ``C``): its delta, current and value are degrees.
ROTATION_UNIT = "deg"


def csv_cell(text: str) -> str:
    """One text cell as every CSV setupfix writes holds it (see the module docstring).

    >>> csv_cell("=HYPERLINK(1)"), csv_cell("a\\rb"), csv_cell("-0.5"), csv_cell("P1 D1")
    ("'=HYPERLINK(1)", 'a\\\\rb', "'-0.5", 'P1 D1')

    Only text cells go through it (a number column is written as a number).
    """
    text = visible_name(text)
    return "'" + text if text.startswith(FORMULA_START) else text


def csv_header() -> str:
    """The header line of the offsets CSV (``../shared/spec/cli-json.md``)."""
    return ",".join(OFFSET_COLUMNS) + "\n"


def csv_lines(rows: Iterable[OffsetRow]) -> str:
    """The data lines of ``rows``, text cells through :func:`csv_cell` (batch appends them report by report);
    a rotation row's unit is :data:`ROTATION_UNIT`."""
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    for r in rows:
        cells = r.cells()
        if r.kind == "wks" and r.axis == "C":  # a rotation is in degrees, whatever the model's length unit
            cells[_UNIT_AT] = ROTATION_UNIT
        for i in _TEXT_AT:
            cells[i] = csv_cell(cells[i])
        writer.writerow(cells)
    return stream.getvalue()


def offsets_csv_text(rows: Iterable[OffsetRow]) -> str:
    """The offsets CSV of ``rows``, header included (the ``csv`` controller's text)."""
    return csv_header() + csv_lines(rows)


def write_offsets_csv(rows: Iterable[OffsetRow], target: Target) -> None:
    """Write the offsets CSV (``../shared/spec/cli-json.md``) atomically; ``-``: standard output."""
    write_text(target, offsets_csv_text(rows))


def write_table_csv(table: pd.DataFrame, target: Target, *, float_format: str = FLOAT_FORMAT) -> None:
    """Write a table as CSV (header, no index, ``\\n`` line ends, missing values empty) atomically."""
    buffer = io.StringIO()
    table.to_csv(buffer, index=False, float_format=float_format, lineterminator="\n")
    write_text(target, buffer.getvalue())


def escape_formulas(table: pd.DataFrame) -> pd.DataFrame:
    """Every text cell through :func:`csv_cell` (formulas prefixed with ``'``, names made visible).

    Only text (object) columns are touched, so numbers such as ``-0.0309`` stay numbers;
    :func:`parsers.canonical.read_canonical` removes the prefix again on reading.
    """
    out = table.copy()
    for col in out.columns:
        if out[col].dtype == object or pd.api.types.is_string_dtype(out[col]):
            text = out[col]
            escaped = text.map(lambda v: csv_cell(v) if isinstance(v, str) else v)
            if not escaped.equals(text):
                out[col] = escaped
    return out


def write_canonical_csv(table: pd.DataFrame, target: Target) -> None:
    """Write a canonical measurement table (``../shared/spec/measurements.md``) as CSV, formulas escaped."""
    write_table_csv(escape_formulas(table), target)


def write_figure(fig: Figure, target: Target) -> None:
    """Write a matplotlib figure as PNG or SVG (by the target's suffix) atomically.

    Raises
    ------
    ExportError
        If the suffix is neither .png nor .svg, or the target cannot be written.
    """
    from setupfix.outputs.plots import figure_format

    fmt = figure_format(target)
    check_target(target)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=120)
    write_bytes(target, buffer.getvalue())
