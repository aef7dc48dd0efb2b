"""Issue 37 item 15, third bullet: a report belongs to a machine; the same file on two machines is two records.

The issue's case was one report processed for M1 and then skipped for M2.  The variant: three guide-pin
reports batched for M1, then for M2 (every one corrected and recorded for M2 too, each machine reading only
its own), then for M2 again (skipped, for M2 only), then for a third machine M3 (corrected again) -- the
claims, reports and recommendations are counted per machine in the store.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.store import ALREADY_PROCESSED, open_store

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"


def batch(folder: Path, db: str, machine: str, out: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    capsys.readouterr()
    argv = ["batch", str(folder), "--model", str(GUIDE / "model.toml"), "--out", str(out)]
    assert main([*argv, "--store", db, "--machine", machine, "--settle", "0", "--json"]) == 0
    summary: dict[str, object] = json.loads(capsys.readouterr().out)
    return summary


def test_the_same_reports_on_two_machines_are_corrected_and_recorded_for_each(
    tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "reports"
    folder.mkdir()
    for k in (2, 3, 4):
        shutil.copy(GUIDE / f"cycle_0{k}.csv", folder)
    runs = {}
    for n, m in enumerate(("M1", "M2", "M2", "M3")):
        runs[n] = batch(folder, location, m, tmp_path / f"out{n}.csv", capsys)
    assert [runs[n]["reports"] for n in range(4)] == [3, 3, 0, 3]
    for m in ("M1", "M2", "M3"):
        with open_store(location, machine=m) as store:
            assert sorted(r.name for r in store.reports()) == ["cycle_02.csv", "cycle_03.csv", "cycle_04.csv"]
            assert {r.machine for r in store.reports()} == {m}
            assert len(store.measurements()) == 3 * 28
            recs = [r for r in store.recommendations() if r.inputs.get("use") == "batch"]
            assert len(recs) == 3 and {r.machine for r in recs} == {m}
    with open_store(location) as store:
        claims = list(store.dump("batch_claim"))
        assert sorted((c[0], c[2]) for c in claims) == [(m, 1) for m in ("M1", "M2", "M3") for _ in range(3)]


def test_a_report_processed_for_one_machine_is_skipped_for_that_machine_only(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "reports"
    folder.mkdir()
    shutil.copy(GUIDE / "cycle_05.csv", folder)
    db = str(tmp_path / "h.db")
    batch(folder, db, "M7", tmp_path / "a.csv", capsys)
    capsys.readouterr()
    argv = ["batch", str(folder), "--model", str(GUIDE / "model.toml"), "--out", str(tmp_path / "b.csv")]
    assert main([*argv, "--store", db, "--machine", "M7", "--settle", "0"]) == 0
    assert ALREADY_PROCESSED in capsys.readouterr().err
    assert main([*argv, "--store", db, "--machine", "M8", "--settle", "0"]) == 0
    assert ALREADY_PROCESSED not in capsys.readouterr().err
