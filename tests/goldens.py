"""Golden-table comparison shared by the reader tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

GOLDEN = Path(__file__).resolve().parent / "parsers" / "golden"
NUMERIC = ["nominal", "actual", "deviation", "lower", "upper", "x", "y", "z"]


def assert_golden(table: pd.DataFrame, golden: Path, prefix: str) -> None:
    """Compare a canonical table with its golden CSV (``source`` made relative to ``prefix``).

    Numeric columns agree to 1e-9 (NaN where the golden cell is empty); text columns exactly.
    """
    got = table.copy()
    got["source"] = got["source"].str.replace(prefix, "", regex=False)
    want = pd.read_csv(golden, dtype=str, keep_default_na=False)
    assert list(got.columns) == list(want.columns)
    assert len(got) == len(want)
    for col in want.columns:
        if col in NUMERIC:
            expected = pd.to_numeric(want[col].replace("", np.nan)).to_numpy(float)
            np.testing.assert_allclose(got[col].to_numpy(float), expected, atol=1e-9, equal_nan=True, err_msg=col)
        else:
            assert got[col].fillna("").astype(str).tolist() == want[col].tolist(), col
