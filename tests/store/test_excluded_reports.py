"""Issue 37 item 1, the store's side: a rejected, failed or draft report is stored for the record, marked,
and left out of what the history reads unless asked.

A variant of the issue's case: the gross report here has P1 D3 at +0.4 mm (the issue's had P1 D1 at
-0.5 mm), stored after four clean guide-pin reports; the rows the history gives back are compared with the
clean reports' own rows, read from the files.  Every test runs on both back ends (``location``).
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.store import EXCLUDED_REASONS, excluded_reports, open_store, report_tables
from setupfix.store.schema import SCHEMA_VERSION, migrate, version_of
from setupfix.usecases.history import migrate_history
from setupfix.usecases.parse import parse_reports

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
CLEAN = sorted(GUIDE.glob("cycle_0*.csv"))[:4]


def gross(tmp_path: Path) -> Path:
    """The fifth cycle with P1 D3 moved to +0.4 mm (far outside ±0.1): a report batch rejects."""
    frame = pd.read_csv(GUIDE / "cycle_05.csv", dtype=str)
    row = frame["characteristic"] == "P1 D3"
    frame.loc[row, "actual"] = f"{float(frame.loc[row, 'nominal'].iloc[0]) + 0.4:.4f}"
    frame.loc[row, "deviation"] = "0.4000"
    path = tmp_path / "cycle_05_gross.csv"
    frame.to_csv(path, index=False)
    return path


def fill(location: str, bad: Path, mark: str | None) -> str:
    """The four clean reports, then ``bad`` with ``mark``; the bad report's content hash."""
    with open_store(location, machine="M1") as store:
        for path in CLEAN:
            store.add_report(path.read_bytes(), path.name, "canonical", parse_reports([path]).table)
        sha, new = store.add_report(bad.read_bytes(), bad.name, "canonical", parse_reports([bad]).table, excluded=mark)
        assert new
    return sha


def test_a_rejected_report_is_kept_for_the_record_but_out_of_the_history(tmp_path: Path, location: str) -> None:
    bad = gross(tmp_path)
    sha = fill(location, bad, "rejected")
    clean = parse_reports(CLEAN).table["deviation"].to_numpy(float)
    with open_store(location, machine="M1") as store:
        assert [r.excluded for r in store.reports()] == [None] * 4 + ["rejected"]
        np.testing.assert_array_equal(store.measurements()["deviation"].to_numpy(float), clean)
        assert set(store.measurements()["report_sha256"]) == {r.sha256 for r in store.reports()[:4]}
        tables = report_tables(store)
        assert [r.name for r, _ in tables] == [p.name for p in CLEAN]
        np.testing.assert_array_equal(np.concatenate([t["deviation"].to_numpy(float) for _, t in tables]), clean)
        assert [(r.name, r.excluded) for r in excluded_reports(store)] == [(bad.name, "rejected")]
        # asked for: the whole history; by its hash: the report whatever its mark
        everything = report_tables(store, include_excluded=True)
        assert [r.name for r, _ in everything] == [*(p.name for p in CLEAN), bad.name]
        assert len(store.measurements(include_excluded=True)) == 5 * 28
        one = store.measurements(sha)
        assert one.loc[one["characteristic"] == "P1 D3", "deviation"].tolist() == [0.4]


@pytest.mark.parametrize("mark", EXCLUDED_REASONS)
def test_the_newest_verdict_rules_the_mark(tmp_path: Path, location: str, mark: str) -> None:
    bad = gross(tmp_path)
    fill(location, bad, None)
    table = parse_reports([bad]).table
    with open_store(location, machine="M1") as store:
        assert excluded_reports(store) == [] and len(report_tables(store)) == 5
        assert store.add_report(bad.read_bytes(), bad.name, "canonical", table, excluded=mark)[1] is False
        assert [r.excluded for r in excluded_reports(store)] == [mark] and len(report_tables(store)) == 4
        store.add_report(bad.read_bytes(), bad.name, "canonical", table, excluded=None)  # corrected again: used
        assert excluded_reports(store) == [] and len(store.measurements()) == 5 * 28
        with pytest.raises(ValueError, match="excluded"):
            store.add_report(bad.read_bytes(), bad.name, "canonical", table, excluded="gross")
    with open_store(location, machine="M2") as store:  # another machine's record of the same bytes: its own mark
        store.add_report(bad.read_bytes(), bad.name, "canonical", table, excluded=mark)
    with open_store(location, machine="M1") as store:
        assert excluded_reports(store) == [] and len(report_tables(store)) == 5


def test_a_v4_store_keeps_its_reports_in_the_history_and_a_migration_copies_the_mark(
    tmp_path: Path, location: str
) -> None:
    """Rows stored before the mark existed are used; ``history migrate`` carries the mark over."""
    old = tmp_path / "v4.db"
    con = sqlite3.connect(old, isolation_level=None)
    migrate(con, str(old), upto=4)
    con.execute(
        "INSERT INTO report (id, sha256, name, format, size, imported_at, machine) "
        "VALUES (1, ?, 'c1.csv', 'canonical', 10, '2026-01-01T00:00:00', 'M1')",
        ("a" * 64,),
    )
    con.execute("INSERT INTO measurement (report_id, row, characteristic, deviation) VALUES (1, 0, 'D1', 0.01)")
    con.close()
    bad = gross(tmp_path)
    with open_store(old, machine="M1") as store:
        assert version_of(store.db) == SCHEMA_VERSION  # type: ignore[attr-defined]
        assert [r.excluded for r in store.reports()] == [None] and len(store.measurements()) == 1
        store.add_report(bad.read_bytes(), bad.name, "canonical", parse_reports([bad]).table, excluded="draft")
    with open_store(old) as source, open_store(location) as target:
        migrate_history(source, target)
    with open_store(location, machine="M1") as store:
        assert [(r.name, r.excluded) for r in store.reports()] == [("c1.csv", None), (bad.name, "draft")]
        assert store.measurements()["deviation"].tolist() == [0.01]
