"""Golden-table comparison shared by the reader tests."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from setupfix.core.errors import Note

GOLDEN = Path(__file__).resolve().parent / "parsers" / "golden"
NUMERIC = ["nominal", "actual", "deviation", "lower", "upper", "x", "y", "z", "nx", "ny", "nz"]


def assert_golden(table: pd.DataFrame, golden: Path, prefix: str) -> None:
    """Compare a canonical table with its golden CSV (``source`` made relative to ``prefix``).

    Numeric columns agree to 1e-9 (NaN where the golden cell is empty); text columns exactly.
    The column list must be equal too: the optional ``axis`` column (:mod:`parsers.axes`) is a
    text column like any other, so a reader that starts stating axes fails here until its
    golden is regenerated on purpose (the readers compared here state none).
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


#: Columns of a "derived" golden: numbers only, for samples whose text may not be copied.
DERIVED = ["line", "part_no", "nominal", "actual", "deviation", "lower", "upper", "status"]


def derived(table: pd.DataFrame) -> pd.DataFrame:
    """The numbers of a canonical table, without text taken from the report."""
    out = pd.DataFrame(
        {
            "line": table["source"].str.rsplit(":", n=1).str[-1].astype(int),
            "part_no": pd.factorize(table["part"])[0] + 1,
        }
    )
    for col in DERIVED[2:]:
        out[col] = table[col]
    return out


def assert_derived_golden(table: pd.DataFrame, golden: Path) -> None:
    """Compare the numbers of a canonical table with a derived golden CSV."""
    got, want = derived(table), pd.read_csv(golden, keep_default_na=False, na_values=[""], dtype={"status": str})
    assert list(want.columns) == DERIVED and len(got) == len(want)
    assert got["line"].tolist() == want["line"].tolist()
    assert got["part_no"].tolist() == want["part_no"].tolist()
    assert got["status"].fillna("").tolist() == want["status"].fillna("").tolist()
    for col in ("nominal", "actual", "deviation", "lower", "upper"):
        np.testing.assert_allclose(got[col].to_numpy(float), want[col].to_numpy(float), atol=1e-9, equal_nan=True)


def note_text(notes: Iterable[Note]) -> str:
    """The notes of a read as lines ``file:line: message`` (as ``setupfix parse`` prints them)."""
    return "\n".join(f"{n.location}: {n.message}" if n.location else n.message for n in notes)


def read_warned(read: Callable[[Path], pd.DataFrame], path: Path) -> tuple[pd.DataFrame, str]:
    """Read ``path``, returning the table and the reader's notes joined."""
    from parsers.notes import collecting

    with collecting() as notes:
        table = read(path)
    return table, note_text(notes)


@contextmanager
def expect_note(pattern: str = "") -> Iterator[list[Note]]:
    """Assert that the reads inside the block leave a note matching ``pattern``."""
    from parsers.notes import collecting

    with collecting() as notes:
        yield notes
    assert notes and re.search(pattern, note_text(notes)), note_text(notes)
