"""Postprocessors: CMM reports in their many formats → the canonical measurement table.

``read(path)`` returns a :class:`pandas.DataFrame` with the columns of
:data:`setupfix.model.CANONICAL_COLUMNS` (lengths in mm, ``deviation`` = actual −
nominal, limits as signed deviations, ``source`` = provenance of each row).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from parsers.canonical import read_canonical

__all__ = ["read"]


def read(path: str | Path, *, format: str | None = None, unit: str | None = None,
         encoding: str | None = None) -> pd.DataFrame:
    """Read one report into the canonical measurement table."""
    return read_canonical(path, unit=unit)
