"""Issue 37 item 1 at the doors: ``diagnose --db`` and ``spc`` say how many marked reports they left out
(text and ``--json``), and ``--include-excluded`` takes them in.

Variant of the issue's case: the store holds cycles 1–5 of the guide pins and a sixth report, marked
failed, whose P4 D7 sits 0.3 mm under.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import parsers
from setupfix.cli import main
from setupfix.store import open_store

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
SAID = "1 stored report(s) marked rejected, failed or draft left out of the series (--include-excluded takes them in)"


@pytest.fixture
def store(tmp_path: Path) -> Path:
    db = tmp_path / "h.db"
    bad = tmp_path / "bad.csv"
    text = (GUIDE / "cycle_05.csv").read_text()
    row = "P4 D7,8.0000,8.0511,0.0511"
    assert row in text
    bad.write_text(text.replace(row, "P4 D7,8.0000,7.7511,-0.2489").replace("cycle 05", "cycle 06"))
    with open_store(db) as s, s.transaction():
        for path in [*(GUIDE / f"cycle_0{i}.csv" for i in range(1, 6)), bad]:
            table = parsers.read_report(path).table
            mark = "failed" if path == bad else None
            s.add_report(path.read_bytes(), path.name, "canonical", table, excluded=mark)
    return db


def run(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    capsys.readouterr()
    assert main(list(args)) == 0
    return capsys.readouterr().out


def test_spc_leaves_the_marked_report_out_says_so_and_takes_it_in_when_asked(
    store: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = json.loads(run(capsys, "spc", "--db", str(store), "--json", "--dimension", "P4 D7"))
    assert doc["excluded_reports"] == 1 and doc["dimensions"][0]["n"] == 5
    clean = doc["dimensions"][0]["cpk"]
    assert any(w.endswith(SAID) for w in doc["warnings"])
    assert f"warning: {SAID}" in run(capsys, "spc", "--db", str(store), "--dimension", "P4 D7")
    doc = json.loads(run(capsys, "spc", "--db", str(store), "--json", "--dimension", "P4 D7", "--include-excluded"))
    assert doc["excluded_reports"] == 0 and doc["dimensions"][0]["n"] == 6
    assert doc["dimensions"][0]["cpk"] < clean / 2 and doc["dimensions"][0]["out_of_tolerance"] == 1


def test_diagnose_leaves_the_marked_report_out_says_so_and_takes_it_in_when_asked(
    store: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = str(GUIDE / "model.toml")
    base = ["diagnose", "--model", model, "--db", str(store), "--no-walk"]
    doc = json.loads(run(capsys, *base, "--json"))
    assert doc["excluded_reports"] == 1 and doc["cycles"] == 5 and SAID in doc["notes"]
    assert doc["next_correction"]["W1"] == pytest.approx(0.005) and doc["rms_before"] == pytest.approx(0.0244, abs=5e-5)
    assert f"note: {SAID}" in run(capsys, *base)
    doc = json.loads(run(capsys, *base, "--json", "--include-excluded"))
    assert doc["excluded_reports"] == 0 and doc["cycles"] == 6 and doc["rms_before"] > 0.03


def test_batch_smoothing_leaves_the_marked_report_out_says_so_once_and_takes_it_in_when_asked(
    store: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "ewma.toml"
    model.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    reports = tmp_path / "new"
    reports.mkdir()
    for k, day in ((7, "08"), (8, "09")):
        text = (GUIDE / "cycle_02.csv").read_text().replace("cycle 02", f"cycle 0{k}")
        (reports / f"cycle_0{k}.csv").write_text(text.replace("2026-11-03T", f"2026-11-{day}T"))
    rows = {}
    for extra in ([], ["--include-excluded"]):
        capsys.readouterr()
        copy = tmp_path / f"copy{len(extra)}.db"
        copy.write_bytes(store.read_bytes())
        out = tmp_path / f"o{len(extra)}.csv"
        args = ["batch", str(reports), "--model", str(model), "--out", str(out), "--store", str(copy), "--settle", "0"]
        assert main([*args, *extra]) == 0
        err = capsys.readouterr().err
        said = err.count("1 stored report(s) marked rejected, failed or draft left out of the smoothing history")
        assert said == (0 if extra else 1), err
        rows[len(extra)] = out.read_text()
    assert rows[0] != rows[1]  # the failed report's 0.3 mm entered the smoothing when asked
