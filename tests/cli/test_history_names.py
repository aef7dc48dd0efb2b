"""Names in and out of the history store: a non-UTF-8 file name, control sequences, formula cells (issue 37, 12)."""

from __future__ import annotations

import csv
import io
import os
import shutil
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main
from setupfix.outputs.writers import FORMULA_START

MODEL = str(GUIDE_PINS / "model.toml")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def store_with_one_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    db = tmp_path / "h.db"
    assert run(capsys, "history", "import", "--db", str(db), str(GUIDE_PINS / "cycle_02.csv"))[0] == 0
    return db


def export(capsys: pytest.CaptureFixture[str], db: Path, table: str, *extra: str) -> list[list[str]]:
    code, out, err = run(capsys, "history", "export", table, "--db", str(db), "--out", "-", *extra)
    assert code == 0, err
    assert "\x1b" not in out and "\x07" not in out  # no control sequence reaches the file
    return list(csv.reader(io.StringIO(out)))


def no_formula(rows: list[list[str]]) -> None:
    """No cell (header included) that a spreadsheet would run."""
    for row in rows:
        for cell in row:
            assert not cell.startswith(FORMULA_START) or _is_number(cell), cell


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


@pytest.mark.skipif(os.name == "nt", reason="file names are bytes on POSIX only")
@pytest.mark.parametrize("door", [["--json"], ["--offsets", "o.csv"], ["--html", "p.html"], []])
def test_a_non_utf8_file_name_is_stored_escaped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, door: list[str]
) -> None:
    db = store_with_one_report(tmp_path, capsys)
    monkeypatch.chdir(tmp_path)
    name = os.fsdecode(b"Pr\xfcfung \x80\xfe 3.csv")  # Latin-1 and stray bytes: lone surrogates in Python
    shutil.copy(GUIDE_PINS / "cycle_03.csv", name)
    code, _, err = run(capsys, "correct", "--model", MODEL, name, "--store", str(db), *door)
    assert code == 0, err
    assert "internal error" not in err and "Traceback" not in err
    rows = export(capsys, db, "recommendations")
    reports = {r[rows[0].index("report")] for r in rows[1:]}
    assert reports == {"Pr\\xfcfung \\x80\\xfe 3.csv"}


def test_an_escape_sequence_in_a_report_name_is_exported_visible(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    db = store_with_one_report(tmp_path, capsys)
    monkeypatch.chdir(tmp_path)
    name = "osc\x1b]0;owned\x07 title.csv"  # an OSC sequence that retitles the operator's terminal
    shutil.copy(GUIDE_PINS / "cycle_04.csv", name)
    assert run(capsys, "correct", "--model", MODEL, name, "--store", str(db), "--json")[0] == 0
    rows = export(capsys, db, "recommendations")
    assert {r[rows[0].index("report")] for r in rows[1:]} == {"osc\\x1b]0;owned\\x07 title.csv"}


def test_machine_operator_and_part_names_are_no_formulas(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = store_with_one_report(tmp_path, capsys)
    report = tmp_path / "r.csv"
    report.write_text((GUIDE_PINS / "cycle_05.csv").read_text().replace("cycle 05", "+cmd|' /C calc'!A0"))
    code, _, err = run(
        capsys,
        "correct",
        "--model",
        MODEL,
        str(report),
        "--store",
        str(db),
        "--machine",
        '=HYPERLINK("http://x")',
        "--operator",
        "@SUM(A1)",
        "--json",
    )
    assert code == 0, err
    rows = export(capsys, db, "recommendations")
    no_formula(rows)
    header = rows[0]
    mine = [r for r in rows[1:] if r[header.index("part")] != "cycle 02"]
    assert mine and {r[header.index("machine")] for r in mine} == {'\'=HYPERLINK("http://x")'}
    assert {r[header.index("operator")] for r in mine} == {"'@SUM(A1)"}
    assert {r[header.index("part")] for r in mine} == {"'+cmd|' /C calc'!A0"}
    for extra in (["--machine", '=HYPERLINK("http://x")'], []):  # one machine, and the whole plant
        no_formula(export(capsys, db, "recommendations", *extra))


def test_channel_headers_and_register_names_are_no_formulas(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "h.db"
    temps = tmp_path / "t.csv"
    temps.write_text("timestamp,=1+1,-spindle,ok\n2026-11-02T08:00:00,20.5,21.0,19.0\n")
    log = tmp_path / "c.csv"
    log.write_text("timestamp,register,delta\n2026-11-02T08:00:00,@W1,0.01\n2026-11-02T09:00:00,W2,-0.02\n")
    code, _, err = run(
        capsys, "history", "import", "--db", str(db), "--temperatures", str(temps), "--corrections", str(log)
    )
    assert code == 0, err
    rows = export(capsys, db, "temperatures")
    no_formula(rows)
    header = rows[0]
    assert sorted(header) == sorted(["timestamp", "'=1+1", "'-spindle", "ok"])
    value = dict(zip(header, rows[1], strict=True))
    assert (value["'=1+1"], value["'-spindle"], value["ok"]) == ("20.5", "21", "19")  # numbers stay numbers
    rows = export(capsys, db, "corrections")
    no_formula(rows)
    registers = [r[rows[0].index("register")] for r in rows[1:]]
    assert registers == ["'@W1", "W2"]
    assert [r[rows[0].index("delta")] for r in rows[1:]] == ["0.01", "-0.02"]  # a negative number is no formula


def test_names_stored_raw_by_an_older_setupfix_are_exported_visible(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A row stored before names were escaped (or by another writer) is escaped on its way out."""
    from setupfix.store import Recommendation, open_store

    db = tmp_path / "h.db"
    with open_store(db, machine="cell\x1b[2J", operator="\x1b]0;x\x07ann") as store:
        store.add_recommendation(
            Recommendation(
                "exact",
                {"report": "old\x1b[31m.csv", "part": "-p\r1", "seed": None},
                {"verdict": "apply", "corrections": {"=W1": 0.01, "T\x1b5": -0.02}},
            )
        )
    rows = export(capsys, db, "recommendations")
    no_formula(rows)
    header = rows[0]
    got = {name: {r[header.index(name)] for r in rows[1:]} for name in ("machine", "operator", "report", "part")}
    assert got == {
        "machine": {"cell\\x1b[2J"},
        "operator": {"\\x1b]0;x\\x07ann"},
        "report": {"old\\x1b[31m.csv"},
        "part": {"'-p\\r1"},
    }
    assert sorted(r[header.index("register")] for r in rows[1:]) == ["'=W1", "T\\x1b5"]
