"""Rows as comparable tuples: the truncation property and the unterminated-last-line check compare tables."""

from __future__ import annotations

import math

import pandas as pd

__all__ = ["ROW_COLUMNS", "row_keys"]

#: The columns a row is compared on (``source``/``report`` name the place, not the value).
ROW_COLUMNS = (
    "characteristic",
    "part",
    "station",
    "nominal",
    "actual",
    "deviation",
    "lower",
    "upper",
    "x",
    "y",
    "z",
    "status",
    "reference",
)


def _cell(value: object) -> object:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else round(value, 9)
    return "" if value is None else str(value)


def row_keys(table: pd.DataFrame) -> list[tuple[object, ...]]:
    """Each row as a comparable tuple of :data:`ROW_COLUMNS` (absent columns empty)."""
    cols = [table[c].tolist() if c in table else [""] * len(table) for c in ROW_COLUMNS]
    return [tuple(_cell(v) for v in row) for row in zip(*cols, strict=True)]
