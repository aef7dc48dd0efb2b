"""The PostgreSQL series read through COPY: the same frame as the row read and as the SQLite store.

Awkward cells on purpose: NULLs in text and numbers, quotes, commas, newlines, non-ASCII text,
doubles whose shortest text has 17 digits, tiny and huge magnitudes, an excluded report; and a
text that is literally the stream's NULL mark, for which the COPY read steps aside.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.model import CANONICAL_COLUMNS
from setupfix.store import open_store
from setupfix.store.pg_copy import NULL_MARK, read_rows
from setupfix.store.postgres import PostgresStore
from setupfix.store.sql import NUMERIC, SQLStore

ROOT = Path(__file__).resolve().parents[2]


def _table(seed: int, n: int, *, text: str = "") -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    names = [f'P{i} "D{i}", ø{i}' if i % 3 == 0 else f"P{i}\nD{i}" if i % 5 == 0 else f"P{i} D{i}" for i in range(n)]
    frame = pd.DataFrame(
        {
            "characteristic": names,
            "nominal": rng.normal(0, 50, n),
            "actual": rng.normal(0, 50, n) * 10.0 ** rng.integers(-12, 12, n),
            "deviation": [np.nan if i % 4 == 0 else 0.1 + 0.2 for i in range(n)],
            "lower": -rng.random(n),
            "upper": rng.random(n),
            "unit": ["mm" if i % 2 else None for i in range(n)],
            "part": f"part {seed}",
            "report": f"r{seed}",
            "timestamp": f"2026-03-0{seed % 9 + 1}T08:00:00",
            "station": [text or None] * n,
            "x": rng.normal(size=n),
            "y": np.nan,
            "z": 1 / 3,
            "status": ["", "ok", "a,b"] * (n // 3) + ["x"] * (n % 3),
            "source": "C:\\cmm\\out.csv",
        }
    )
    return frame.reindex(columns=list(CANONICAL_COLUMNS))


def _fill(location: str, tables: list[pd.DataFrame]) -> None:
    with open_store(location, machine="m1") as store:
        for i, t in enumerate(tables):
            store.add_report(f"r{i}".encode(), f"r{i}.csv", "canonical", t, excluded="rejected" if i == 1 else None)


@pytest.mark.parametrize("include_excluded", [False, True])
def test_copy_read_equals_row_read_and_sqlite(tmp_path: Path, pg_url: str, include_excluded: bool) -> None:
    tables = [_table(seed, 13) for seed in range(4)]
    _fill(pg_url, tables)
    _fill(str(tmp_path / "h.db"), tables)
    with open_store(pg_url, machine="m1") as pg, open_store(str(tmp_path / "h.db"), machine="m1") as lite:
        assert isinstance(pg, PostgresStore)
        copied = read_rows(pg.conn, "m1", include_excluded=include_excluded, columns=CANONICAL_COLUMNS, numeric=NUMERIC)
        assert copied is not None  # the COPY path itself, not the fallback
        rows = SQLStore.measurements(pg, include_excluded=include_excluded)
        public = pg.measurements(include_excluded=include_excluded)
        embedded = lite.measurements(include_excluded=include_excluded)
    assert len(copied) == 13 * (4 if include_excluded else 3)
    for other in (rows, public, embedded):
        pd.testing.assert_frame_equal(copied, other, check_exact=True)
        assert [str(t) for t in copied.dtypes] == [str(t) for t in other.dtypes]
    # bit for bit, not only within a tolerance
    for c in NUMERIC:
        assert np.array_equal(copied[c].to_numpy().view(np.int64), rows[c].to_numpy().view(np.int64))


def test_a_text_equal_to_the_null_mark_falls_back_to_the_row_read(pg_url: str) -> None:
    _fill(pg_url, [_table(0, 6), _table(2, 6, text=NULL_MARK)])
    with open_store(pg_url, machine="m1") as pg:
        assert isinstance(pg, PostgresStore)
        assert read_rows(pg.conn, "m1", include_excluded=True, columns=CANONICAL_COLUMNS, numeric=NUMERIC) is None
        frame = pg.measurements(include_excluded=True)
        pd.testing.assert_frame_equal(frame, SQLStore.measurements(pg, include_excluded=True), check_exact=True)
    assert list(frame["station"].iloc[-6:]) == [NULL_MARK] * 6


def test_no_rows_keeps_the_empty_frame(pg_url: str) -> None:
    with open_store(pg_url, machine="m1") as pg:
        assert isinstance(pg, PostgresStore)
        assert read_rows(pg.conn, "m1", include_excluded=False, columns=CANONICAL_COLUMNS, numeric=NUMERIC) is None
        pd.testing.assert_frame_equal(pg.measurements(), SQLStore.measurements(pg))


def test_the_read_inside_a_store_transaction_keeps_the_session_settings(pg_url: str) -> None:
    _fill(pg_url, [_table(0, 6), _table(1, 6)])
    with open_store(pg_url, machine="m1") as pg:
        assert isinstance(pg, PostgresStore)
        before = pg.conn.execute("SHOW jit").fetchone()
        with pg.transaction():
            inside = pg.measurements(include_excluded=True)
        assert pg.conn.execute("SHOW jit").fetchone() == before  # JIT is off for the read's statement only
        pd.testing.assert_frame_equal(inside, SQLStore.measurements(pg, include_excluded=True), check_exact=True)
