"""What goes into the store marked, and what its exports leave out (issue 37, item 1: the writer side).

``batch --store`` and ``correct --store`` mark a rejected or draft-model report; ``history export
dfq`` and ``measurements`` leave it out, say how many, and ``--include-excluded`` takes it in.
On SQLite and on the PostgreSQL test server alike (:mod:`pgserver`).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import GUIDE_PINS
from pgserver import location, pg_url

import parsers
from setupfix.cli import main

__all__ = ["location", "pg_url"]

MODEL = str(GUIDE_PINS / "model.toml")
ROWS_PER_REPORT = 28


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "internal error" not in err
    return code, out, err


def gross_copy(source: Path, target: Path) -> Path:
    """``source`` with P2 D6 measured 0.48 mm under (a gross value the safety rules reject)."""
    text = source.read_text()
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith("P2 D6,"))
    cells = lines[i].split(",")
    cells[2], cells[3] = f"{float(cells[1]) - 0.48:.4f}", "-0.4800"
    lines[i] = ",".join(cells)
    target.write_text("\n".join(lines) + "\n")
    return target


def dfq_values(path: Path) -> int:
    return len(parsers.read_report(path).table)


def test_batch_marks_a_rejected_report_and_the_exports_leave_it_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], location: str
) -> None:
    d = tmp_path / "in"
    d.mkdir()
    for i in (1, 3, 5):
        shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    gross_copy(GUIDE_PINS / "cycle_04.csv", d / "cycle_04.csv")
    code, out, err = run(
        capsys,
        "batch",
        "--model",
        MODEL,
        str(d),
        "--out",
        str(tmp_path / "o.csv"),
        "--settle",
        "0",
        "--store",
        location,
    )
    assert "1 reject" in out, (out, err)
    code, out, _ = run(capsys, "history", "show", "--db", location, "--machine", "default", "--json")
    marks = {r["report"]: r["excluded"] for r in json.loads(out)["reports"]}
    assert marks == {"cycle_01.csv": None, "cycle_03.csv": None, "cycle_05.csv": None, "cycle_04.csv": "rejected"}
    _, out, _ = run(capsys, "history", "show", "--db", location, "--machine", "default")
    assert [line.split()[0] for line in out.splitlines() if line.endswith("excluded: rejected")] == ["cycle_04.csv"]
    dfq = tmp_path / "h.dfq"
    code, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert code == 0 and "left out 1 report(s) marked excluded (1 rejected)" in err
    assert dfq_values(dfq) == 3 * ROWS_PER_REPORT
    code, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq), "--include-excluded")
    assert code == 0 and "taken in" in err and dfq_values(dfq) == 4 * ROWS_PER_REPORT
    csv_out = tmp_path / "m.csv"
    code, _, err = run(capsys, "history", "export", "measurements", "--db", location, "--out", str(csv_out))
    assert code == 0 and "left out 1 report(s)" in err
    assert len(csv_out.read_text().splitlines()) == 1 + 3 * ROWS_PER_REPORT
    code, _, _ = run(
        capsys, "history", "export", "measurements", "--db", location, "--out", str(csv_out), "--include-excluded"
    )
    assert len(csv_out.read_text().splitlines()) == 1 + 4 * ROWS_PER_REPORT


def test_correct_store_marks_a_report_the_store_holds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], location: str
) -> None:
    gross = gross_copy(GUIDE_PINS / "cycle_02.csv", tmp_path / "gross.csv")
    clean = GUIDE_PINS / "cycle_03.csv"
    assert run(capsys, "history", "import", "--db", location, str(gross), str(clean))[0] == 0
    dfq = tmp_path / "h.dfq"
    run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert dfq_values(dfq) == 2 * ROWS_PER_REPORT  # imported: nothing known against it yet
    code, _, err = run(capsys, "correct", "--model", MODEL, str(gross), "--store", location, "--json")
    assert code != 0 and "reject" in err.lower()
    _, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert dfq_values(dfq) == ROWS_PER_REPORT and "(1 rejected)" in err
    # importing it again gives no verdict: the mark stays
    assert run(capsys, "history", "import", "--db", location, str(gross))[0] == 0
    _, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert dfq_values(dfq) == ROWS_PER_REPORT and "(1 rejected)" in err
    # a draft model's correction marks the clean one draft
    draft = tmp_path / "draft.toml"
    text = Path(MODEL).read_text()
    assert "[process]" in text
    draft.write_text(text.replace("[process]", "[process]\ndraft = true", 1))
    run(capsys, "correct", "--model", str(draft), str(clean), "--store", location, "--json")
    _, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert "left out 2 report(s) marked excluded (1 draft, 1 rejected)" in err
    # the newest verdict rules: the clean report corrected with the real model is taken back in
    assert run(capsys, "correct", "--model", MODEL, str(clean), "--store", location, "--json")[0] == 0
    _, _, err = run(capsys, "history", "export", "dfq", "--db", location, "--out", str(dfq))
    assert dfq_values(dfq) == ROWS_PER_REPORT and "left out 1 report(s) marked excluded (1 rejected)" in err


def test_a_batch_says_how_many_marked_reports_its_history_left_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = str(tmp_path / "h.db")
    first = tmp_path / "first"
    first.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_01.csv", first / "cycle_01.csv")
    gross_copy(GUIDE_PINS / "cycle_02.csv", first / "cycle_02.csv")
    argv = ["batch", "--model", MODEL, "--settle", "0", "--store", db]
    _, out, err = run(capsys, *argv, str(first), "--out", str(tmp_path / "a.csv"))
    assert "left out of the history" not in err  # nothing was marked before this run
    assert "1 reject" in out
    second = tmp_path / "second"
    second.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_03.csv", second / "cycle_03.csv")
    _, _, err = run(capsys, *argv, str(second), "--out", str(tmp_path / "b.csv"))
    assert "warning: 1 stored report(s) marked rejected, failed or draft left out of the history" in err
