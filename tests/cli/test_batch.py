"""`setupfix batch` end to end: exit status, summary, stderr, a killed run leaves no file."""

from __future__ import annotations

import json
import shutil
import signal
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main

MODEL = str(GUIDE_PINS / "model.toml")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_exit_status_summary_and_bad_file_named(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_01.csv", d / "a.csv")
    code, out, err = run(
        capsys, "batch", "--model", MODEL, str(d), "--out", str(tmp_path / "o.csv"), "--settle", "0", "--json"
    )
    assert code == 0 and json.loads(out)["verdicts"] == {"apply": 1} and "[1/1]" in err
    (d / "broken.csv").write_text("characteristic,nominal,actual\nP1 D1,25,abc\n")
    code, out, err = run(capsys, "batch", "--model", MODEL, str(d), "--out", str(tmp_path / "o.csv"), "--settle", "0")
    assert code == 4
    assert "1 report(s), 1 part(s): 1 apply, 0 hold, 0 reject" in out and "1 failed" in out
    assert "broken.csv:2: column 'actual'" in err and "Traceback" not in err
    code, _, err = run(capsys, "batch", "--model", MODEL, str(tmp_path / "nope"), "--out", str(tmp_path / "o.csv"))
    assert code == 1 and "is not a folder" in err


def test_killed_run_leaves_no_partial_file(tmp_path: Path) -> None:
    """SIGTERM becomes KeyboardInterrupt (the CLI's handler), which unwinds the atomic writer."""
    import pytest

    from setupfix.cli.batch import terminate
    from setupfix.model import load_model
    from setupfix.usecases.batch import run_batch
    from setupfix.usecases.requests import CorrectRequest

    d = tmp_path / "in"
    d.mkdir()
    for i in range(3):  # distinct contents, so none is skipped as a duplicate
        text = (GUIDE_PINS / "cycle_01.csv").read_text().replace("2026-11-02T08:00:00", f"2026-11-02T08:{i:02d}:00")
        (d / f"r{i:03d}.csv").write_text(text)
    out = tmp_path / "o.csv"

    def killed_after_first(done: int, total: int, outcome: object) -> None:
        assert any(p.name.endswith(".tmp") for p in tmp_path.iterdir())  # rows are being streamed …
        terminate(signal.SIGTERM, None)

    with pytest.raises(KeyboardInterrupt):
        run_batch(CorrectRequest(load_model(MODEL)), d, out, settle=0, progress=killed_after_first)
    assert [p.name for p in tmp_path.iterdir()] == ["in"]  # … and neither output nor temporary file is left


@pytest.mark.slow
def test_batch_store_smooths_as_correct_store_does(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """Issue 20: with ``ewma = 0.5`` and the guide-pins cycles 1–5, ``batch --store`` differed from ``correct
    --store`` in 36 register values (batch never smoothed); now every value agrees."""
    import csv

    model = tmp_path / "ewma.toml"
    model.write_text((GUIDE_PINS / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    d = tmp_path / "in"
    d.mkdir()
    reports = [shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv") for i in range(1, 6)]
    code, _, err = run(
        capsys,
        "batch",
        "--model",
        str(model),
        str(d),
        "--out",
        str(tmp_path / "batch.csv"),
        "--settle",
        "0",
        "--store",
        str(tmp_path / "batch.db"),
    )
    assert code == 0 and "needs the history store" not in err
    code, _, err = run(
        capsys, "history", "import", "--db", str(tmp_path / "h.db"), "--model", str(model), *map(str, reports)
    )
    assert code == 0, err
    expected: dict[tuple[str, str], float] = {}
    plain: dict[tuple[str, str], float] = {}
    for report in reports:
        for db, into in ((["--store", str(tmp_path / "h.db")], expected), ([], plain)):
            code, out, _ = run(capsys, "correct", "--model", str(model), str(report), "--json", *db)
            into.update({(Path(report).name, k): v for k, v in json.loads(out)["corrections"].items()})
    with (tmp_path / "batch.csv").open() as f:
        got = {(row["report"], row["id"]): float(row["delta"]) for row in csv.DictReader(f)}
    assert got == expected and sum(expected[k] != plain[k] for k in expected) >= 30


def test_bad_thermal_inputs_are_refused_before_any_work(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_01.csv", d / "a.csv")
    out = tmp_path / "o.csv"
    code, _, err = run(
        capsys,
        "batch",
        "--model",
        MODEL,
        str(d),
        "--out",
        str(out),
        "--settle",
        "0",
        "--thermal",
        str(tmp_path / "missing.json"),
    )
    assert code == 1 and "go together" in err and not out.exists()
    code, _, err = run(
        capsys,
        "batch",
        "--model",
        MODEL,
        str(d),
        "--out",
        str(out),
        "--settle",
        "0",
        "--thermal",
        str(tmp_path / "missing.json"),
        "--temperatures",
        str(GUIDE_PINS / "cycle_01.csv"),
    )
    assert code == 1 and "missing.json" in err and "Traceback" not in err and not out.exists()
