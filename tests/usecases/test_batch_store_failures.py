"""A batch whose history store fails part way says truly what it stored (issue 37, item 15).

Each report is stored with its recommendations in one transaction: after a failure at
the k-th write the store holds whole reports, each with its recommendations, and the
message counts them -- never "nothing stored" when something was.  A store that fails
from its k-th write on (a full disk: :class:`FailingFrom`) and a PostgreSQL connection
cut by the server part way; the rows are counted afterwards through a new handle.
"""

from __future__ import annotations

import hashlib
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import pytest
from conftest import GUIDE_PINS
from pgserver import pg_url

from setupfix.core.errors import SourceLocation, StoreError
from setupfix.model import load_model
from setupfix.store import Store, open_store
from setupfix.usecases.batch import run_batch
from setupfix.usecases.batch_records import Outcome
from setupfix.usecases.requests import CorrectRequest

__all__ = ["pg_url"]

MODEL = GUIDE_PINS / "model.toml"
WRITES = ("add_report", "add_recommendation", "finish_claims")


class FailingFrom:
    """A store whose ``k``-th write and every later one fail as a full disk does (reads go on)."""

    def __init__(self, store: Store, k: int) -> None:
        self.store, self.k, self.writes = store, k, 0

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.store, name)
        if name not in WRITES:
            return attr

        def write(*args: Any, **kwargs: Any) -> Any:
            self.writes += 1
            if self.writes >= self.k:
                raise StoreError(
                    "the history store cannot grow: the disk is full; nothing was stored",
                    location=SourceLocation(self.store.location),
                )
            return attr(*args, **kwargs)

        return write


def reports(tmp_path: Path, n: int) -> Path:
    """``n`` distinct reports (cycles 1-5 with parts and times of their own)."""
    d = tmp_path / "in"
    d.mkdir()
    for k in range(n):
        text = (GUIDE_PINS / f"cycle_0{k % 5 + 1}.csv").read_text()
        (d / f"r{k:02d}.csv").write_text(text.replace(f"cycle 0{k % 5 + 1}", f"part {k:02d}"))
    return d


def whole_reports(location: str, runs: int = 1) -> int:
    """The stored reports, checked to have each its recommendation (one part per report) from each of
    at most ``runs`` runs (a report stored by a failed run is corrected again by the next: not processed)."""
    with open_store(location) as store:
        held = {r.sha256 for r in store.reports()}
        recommended = [r.inputs["report"] for r in store.recommendations()]
    assert set(recommended) == held  # no report without its recommendation, none without its report
    assert all(1 <= recommended.count(h) <= runs for h in held)
    return len(held)


@pytest.mark.parametrize("k", [4, 7])
def test_a_store_failing_from_the_kth_write_keeps_whole_reports_and_counts_them(tmp_path: Path, k: int) -> None:
    """Writes per report: its report row, its recommendation; the k-th write fails and so do all later."""
    d = reports(tmp_path, 6)
    db = str(tmp_path / "h.db")
    with open_store(db) as real:
        failing = FailingFrom(real, k)
        with pytest.raises(StoreError) as info:
            run_batch(CorrectRequest(load_model(MODEL)), d, tmp_path / "o.csv", settle=0, store=cast(Store, failing))
    stored = (k - 1) // 2  # whole reports before the failing write
    assert whole_reports(db) == stored
    message = str(info.value)
    assert f"{stored} report(s) of this run were stored, each with its recommendations" in message
    assert "nothing was stored" not in message and "disk is full" in message
    assert (tmp_path / "o.csv").is_file()  # the offsets were written: the hint says so
    assert "the output was written" in message
    # the next run, on a store that works again, corrects the rest and stores each once
    with open_store(db) as store:
        summary = run_batch(CorrectRequest(load_model(MODEL)), d, tmp_path / "o2.csv", settle=0, store=store)
    assert summary.reports == 6 and whole_reports(db, runs=2) == 6


def test_a_failed_report_is_named_with_what_was_stored_before_it(tmp_path: Path) -> None:
    d = reports(tmp_path, 4)
    db = str(tmp_path / "h.db")
    with open_store(db) as real:
        failing = FailingFrom(real, 6)  # the third report's row: that one and the fourth are not stored
        with pytest.raises(StoreError):
            run_batch(CorrectRequest(load_model(MODEL)), d, tmp_path / "o.csv", settle=0, store=cast(Store, failing))
    assert whole_reports(db) == 2


def cut_after(url: str, n: int) -> Callable[[int, int, Outcome], None]:
    """A progress callback that has the server end every other connection to the database after ``n`` reports."""
    import psycopg

    def progress(done: int, total: int, outcome: Outcome) -> None:
        if done == n:
            with psycopg.connect(url, autocommit=True) as admin:
                admin.execute(
                    "SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                    "WHERE datname = current_database() AND pid <> pg_backend_pid()"
                )

    return progress


def test_a_connection_cut_part_way_leaves_whole_reports_and_says_how_many(tmp_path: Path, pg_url: str) -> None:
    d = reports(tmp_path, 5)
    with open_store(pg_url) as store, pytest.raises(StoreError) as info:
        run_batch(
            CorrectRequest(load_model(MODEL)),
            d,
            tmp_path / "o.csv",
            settle=0,
            store=store,
            progress=cut_after(pg_url, 3),
        )
    message = str(info.value)
    held = whole_reports(pg_url)
    assert held == 3
    assert f"{held} report(s) of this run were stored" in message and "nothing of the current" not in message
    assert "password" not in message.lower() or "***" in message
    # (the claims stay with this process while it lives: a batch's process ends with its failure, and the
    # next run takes them over -- the SQLite test above runs it)


def test_report_hashes_are_the_recommendations_keys(tmp_path: Path) -> None:
    """The check above pairs a report with its recommendation by the report's content hash."""
    d = reports(tmp_path, 2)
    db = str(tmp_path / "h.db")
    with open_store(db) as store:
        run_batch(CorrectRequest(load_model(MODEL)), d, tmp_path / "o.csv", settle=0, store=store)
        keys = {r.inputs["report"] for r in store.recommendations()}
    assert keys == {hashlib.sha256(p.read_bytes()).hexdigest() for p in d.iterdir()}
    shutil.rmtree(d)
