"""Issue 37 item 1 at ``correct --store`` and ``compare --store``: a stored report marked rejected, failed or
draft is left out of the EWMA smoothing (the answer is the clean store's), the notes count it, and
``--include-excluded`` takes it in (the answer then moves).

Variant of the issue's case: the gross part is P2 D1 at +0.45 mm, marked rejected.
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


def _store(db: Path, tmp_path: Path, *, with_gross: bool) -> Path:
    reports = [GUIDE / f"cycle_0{i}.csv" for i in range(1, 4)]
    gross = tmp_path / "gross.csv"
    text = (GUIDE / "cycle_04.csv").read_text()
    rows = [line for line in text.splitlines() if line.startswith("P2 D1,")]
    assert len(rows) == 1
    nominal = float(rows[0].split(",")[1])
    bad = f"P2 D1,{nominal:.4f},{nominal + 0.45:.4f},0.4500"
    gross.write_text(text.replace(rows[0], bad).replace("cycle 04", "cycle 09"))
    with open_store(db) as s, s.transaction():
        for path in [*reports, *([gross] if with_gross else [])]:
            table = parsers.read_report(path).table
            mark = "rejected" if path == gross else None
            s.add_report(path.read_bytes(), path.name, "canonical", table, excluded=mark)
    return db


def _corrections(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[dict[str, float], list[str]]:
    capsys.readouterr()
    assert main(list(args)) == 0
    doc = json.loads(capsys.readouterr().out)
    cycle = doc["cycles"][0] if "cycles" in doc else doc
    deltas = {k: float(v) for k, v in cycle["corrections"].items()}
    return deltas, [str(n) for n in cycle["warnings"]]


@pytest.fixture
def model(tmp_path: Path) -> Path:
    path = tmp_path / "ewma.toml"
    path.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    return path


def test_correct_store_leaves_a_marked_report_out_of_the_smoothing_unless_asked(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    marked = _store(tmp_path / "marked.db", tmp_path, with_gross=True)
    clean = _store(tmp_path / "clean.db", tmp_path, with_gross=False)
    report = str(GUIDE / "cycle_05.csv")
    base = ["correct", "--model", str(model), report, "--json"]
    left_out, notes = _corrections(capsys, *base, "--store", str(marked))
    assert left_out == _corrections(capsys, *base, "--store", str(clean))[0]
    assert any("1 " in n and "left out" in n for n in notes), notes
    taken_in, _ = _corrections(capsys, *base, "--store", str(marked), "--include-excluded")
    assert max(abs(taken_in[k] - left_out[k]) for k in left_out) > 0.005
