"""Issue 21 item 6: two batches on one store correct each report once; a killed batch leaves no worker.

Real processes: two ``setupfix batch --store`` runs at once over one folder, and a SIGKILL of
``batch --workers 2`` (its workers looked up in /proc, or psutil when installed).
"""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from setupfix.store import ALREADY_PROCESSED, Claimant, open_store

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def reports(folder: Path, n: int) -> list[Path]:
    """``n`` distinct reports (the guide-pin cycles, each with its own part name)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for k in range(n):
        text = (GUIDE / f"cycle_0{k % 5 + 1}.csv").read_text().replace(f"cycle 0{k % 5 + 1}", f"part {k:03d}")
        path = folder / f"r{k:03d}.csv"
        path.write_text(text)
        out.append(path)
    return out


def batch(folder: Path, db: str | Path, out: Path, *extra: str) -> subprocess.Popen[str]:
    """``batch --store`` with a 60 s solve limit: the claims are the subject here, and on a loaded box the
    default 2 s may stop a solve (exit 6, the report left unprocessed: right, but another test's subject)."""
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "setupfix",
            "batch",
            str(folder),
            "--model",
            str(GUIDE / "model.toml"),
            "--out",
            str(out),
            "--store",
            str(db),
            "--settle",
            "0",
            "--time-limit",
            "60",
            "--json",
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )


def stored_batch_reports(db: str | Path) -> list[str]:
    with open_store(db) as store:
        return [str(r.inputs["report"]) for r in store.recommendations() if r.inputs.get("use") == "batch"]


def claims_of(db: str | Path) -> tuple[int, int, int]:
    """(claim rows, reports processed, claims held) of the store ``db``."""
    with open_store(db) as store:
        rows = list(store.dump("batch_claim"))
    return len(rows), sum(r[2] for r in rows), sum(r[3] is not None for r in rows)


@pytest.mark.slow
def test_two_batches_at_once_correct_every_report_exactly_once(tmp_path: Path, location: str) -> None:
    n = 40
    folder = tmp_path / "reports"
    reports(folder, n)
    db = location
    open_store(db).close()  # both runs find the store (its creation at once is another test)
    runs = [batch(folder, db, tmp_path / f"out{i}.csv", "--workers", "1") for i in (1, 2)]
    results = [p.communicate(timeout=600) for p in runs]
    summaries = []
    for p, (out, err) in zip(runs, results, strict=True):
        assert p.returncode == 0, err
        summaries.append(json.loads(out))
    assert sum(s["reports"] for s in summaries) == n
    for s in summaries:
        assert s["failed"] == []
        assert all("another run" in k["reason"] or k["reason"] == ALREADY_PROCESSED for k in s["skipped"]), s
    named = [
        line.split(",")[0]
        for i in (1, 2)
        if (tmp_path / f"out{i}.csv").exists()
        for line in (tmp_path / f"out{i}.csv").read_text().splitlines()[1:]
    ]
    per_report = {name for name in named}
    assert len(per_report) == n  # every report has its rows in exactly one of the outputs
    stored = stored_batch_reports(db)
    assert len(stored) == n and len(set(stored)) == n  # one recommendation each: corrected once in total
    assert claims_of(db) == (n, n, 0)


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (psutil when installed, else /proc)."""
    try:
        import psutil
    except ImportError:
        kids = []
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    stat = Path(f"/proc/{entry}/stat").read_text()
                except OSError:
                    continue
                if int(stat[stat.rfind(")") + 2 :].split()[1]) == pid:
                    kids.append(int(entry))
        return kids
    return [c.pid for c in psutil.Process(pid).children(recursive=True)]


def _running(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rfind(")") + 2 :].split()[0] != "Z"  # a zombie has ended


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="looks the workers up in /proc")
def test_sigkill_of_a_batch_leaves_no_worker_and_its_claims_are_taken_over(tmp_path: Path, location: str) -> None:
    folder = tmp_path / "reports"
    reports(folder, 60)
    db = location
    run = batch(folder, db, tmp_path / "out.csv", "--workers", "2")
    deadline = time.monotonic() + 120
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        workers = [w for w in _children(run.pid) if _running(w)]
        time.sleep(0.05)
    assert len(workers) == 2, "the batch started no workers"
    time.sleep(0.5)  # the workers are correcting, the batch holds claims
    os.kill(run.pid, signal.SIGKILL)
    run.wait()  # not communicate(): surviving workers would hold its pipes open
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and any(_running(w) for w in workers):
        time.sleep(0.1)
    survivors = [w for w in workers if _running(w)]
    for w in survivors:  # never leave them behind, even when the test fails
        os.kill(w, signal.SIGKILL)
    run.stdout.close()  # type: ignore[union-attr]
    run.stderr.close()  # type: ignore[union-attr]
    assert not survivors, "workers outlived the killed batch"
    assert claims_of(db)[2] > 0  # the kill left claims behind ...
    again = batch(folder, db, tmp_path / "again.csv", "--workers", "1")
    out, err = again.communicate(timeout=600)
    assert again.returncode == 0, err
    summary = json.loads(out)
    assert summary["reports"] == 60 and summary["skipped"] == []  # ... which the next run takes over


def test_claims_refuse_a_live_holder_and_processed_reports_take_over_a_dead_one(location: str) -> None:
    store = open_store(location)
    me = Claimant.this_run()
    other_live = Claimant("other", me.host, os.getppid(), "")  # pytest's parent runs
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    gone = Claimant("gone", me.host, int(dead.stdout), "")
    assert store.claim_reports(["a"], other_live) == {}
    assert store.claim_reports(["b"], gone) == {}
    refused = store.claim_reports(["a", "b", "c"], me)
    assert list(refused) == ["a"] and "another run" in refused["a"] and str(os.getppid()) in refused["a"]
    store.finish_claims(["b", "c"], me)
    assert store.claim_reports(["b"], other_live) == {"b": ALREADY_PROCESSED}
    assert store.claim_reports(["b"], other_live, again=True) == {}  # --force
    assert "another run" in store.claim_reports(["b"], me, again=True)["b"]
    store.release_claims(other_live)
    assert store.claim_reports(["b"], me) == {"b": ALREADY_PROCESSED}  # a released --force run keeps it done
    assert store.claim_reports(["a"], me) == {}  # freed
    far = Claimant("far", "another-host", 1, "")
    store.release_claims(me)
    assert store.claim_reports(["z"], far) == {}
    assert "another run" in store.claim_reports(["z"], me).get("z", "")  # another host: stale only when old
    with store.transaction():  # the far claim grows old
        store._execute(  # type: ignore[attr-defined]  # both back ends have it; the Store protocol does not
            "UPDATE batch_claim SET claimed_at = '2000-01-01T00:00:00+00:00' WHERE owner = 'far'"
        )
    store.close()
    with open_store(location) as store:
        assert store.claim_reports(["z"], me) == {}


def test_a_store_of_older_batches_keeps_its_processed_reports(tmp_path: Path) -> None:
    """Migration 3 marks the reports older batch recommendations name as processed."""
    from setupfix.store import Recommendation
    from setupfix.store.schema import migrate

    path = tmp_path / "old.db"
    con = sqlite3.connect(path, isolation_level=None)
    migrate(con, str(path), upto=2)
    con.close()
    with sqlite3.connect(path) as con:
        con.execute(
            "INSERT INTO recommendation (created_at, optimizer, inputs, result) VALUES "
            "('2026-01-01', 'exact', '{\"use\": \"batch\", \"report\": \"abc\"}', '{}'), "
            "('2026-01-01', 'exact', '{\"report\": \"def\"}', '{}')"
        )
    con.close()
    with open_store(path) as store:
        me = Claimant.this_run()
        assert store.claim_reports(["abc", "def"], me) == {"abc": ALREADY_PROCESSED}
        assert isinstance(store.recommendations()[0], Recommendation)


@pytest.mark.slow
def test_a_store_that_cannot_finish_the_claims_says_the_output_stands_and_the_next_run_redoes_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The store refuses to write once the output is written: one line naming the store, the offsets in place,
    the reports stored whole with their recommendations but none marked processed, so the next run corrects
    them again (the connection is query-only while the claims finish: SQLITE_READONLY)."""
    from setupfix.cli import main
    from setupfix.usecases import batch_records

    folder = tmp_path / "reports"
    reports(folder, 60)
    db, out = tmp_path / "h.db", tmp_path / "out.csv"
    real = batch_records.Claims.finish

    def full(self: batch_records.Claims) -> None:
        con = self.store.db  # type: ignore[attr-defined]  # the SQLite store's connection
        con.execute("PRAGMA query_only = ON")
        try:
            return real(self)
        finally:
            con.execute("PRAGMA query_only = OFF")  # (the claims are then freed, as after a full disk)

    monkeypatch.setattr(batch_records.Claims, "finish", full)
    argv = [
        "batch",
        str(folder),
        "--model",
        str(GUIDE / "model.toml"),
        "--out",
        str(out),
        "--store",
        str(db),
        "--settle",
        "0",
    ]
    assert main(argv) == 1
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.startswith("error:"))
    assert "h.db" in line and "cannot be written" in line and "corrected again by the next run" in line
    assert "60 report(s) of this run were stored" in line
    assert len(out.read_text().splitlines()) > 1
    monkeypatch.undo()
    assert len(set(stored_batch_reports(db))) == 60 and claims_of(db)[1:] == (0, 0)
    assert main([*argv, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["reports"] == 60
