"""Every result file setupfix writes, in one place (layer 4: the engine writes no files).

The primitives come from :mod:`setupfix.atomic`: :func:`check_target` (``-`` for
standard output or a regular file, new or existing; a folder, device, FIFO, socket
or symbolic link is refused with an :class:`~setupfix.errors.ExportError` naming
it), :func:`write_text` and :func:`write_bytes` (atomic: complete or absent).
Commands call :func:`check_target` on every output before any work, so a bad
target costs nothing.

The format writers below turn a result into bytes and hand them to those
primitives; each has a write → read round trip test.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterable
from typing import TYPE_CHECKING

import pandas as pd

from setupfix.atomic import atomic_write, check_target, write_bytes, write_text
from setupfix.offsets import OffsetRow, offsets_csv_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["check_target", "write_text", "write_bytes", "atomic_write", "write_offsets_csv",
           "write_canonical_csv", "escape_formulas", "write_figure", "write_table_csv", "FLOAT_FORMAT"]

Target = str | os.PathLike[str]

#: Lengths are written with 12 significant digits: exact for every report value
#: (≤ 7 decimals in the samples) and free of binary noise in actual − nominal.
FLOAT_FORMAT = "%.12g"


def write_offsets_csv(rows: Iterable[OffsetRow], target: Target, *, resolution: float = 0.001) -> None:
    """Write the offsets CSV (``../shared/spec/cli-json.md``) atomically; ``-``: standard output."""
    write_text(target, offsets_csv_text(rows, resolution=resolution))


def write_table_csv(table: pd.DataFrame, target: Target, *, float_format: str = FLOAT_FORMAT) -> None:
    """Write a table as CSV (header, no index, ``\\n`` line ends, missing values empty) atomically."""
    buffer = io.StringIO()
    table.to_csv(buffer, index=False, float_format=float_format, lineterminator="\n")
    write_text(target, buffer.getvalue())


#: First characters that make a spreadsheet read a cell as a formula (``=HYPERLINK(…)``, ``@SUM``, …).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def escape_formulas(table: pd.DataFrame) -> pd.DataFrame:
    """Text cells that a spreadsheet would run as a formula, prefixed with ``'`` (OWASP CSV injection).

    Only text (object) columns are touched, so numbers such as ``-0.0309`` stay numbers;
    :func:`parsers.canonical.read_canonical` removes the prefix again on reading.
    """
    out = table.copy()
    for col in out.columns:
        if out[col].dtype == object or pd.api.types.is_string_dtype(out[col]):
            text = out[col]
            risky = text.map(lambda v: isinstance(v, str) and v.startswith(FORMULA_START))
            if risky.any():
                out[col] = text.where(~risky, "'" + text.astype(str))
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
    from setupfix.plots import figure_format

    fmt = figure_format(target)
    check_target(target)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=120)
    write_bytes(target, buffer.getvalue())
