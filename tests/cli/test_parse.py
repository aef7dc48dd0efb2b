"""``setupfix parse`` and ``setupfix formats``, in-process."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.cli.exit_codes import ERROR, OK, PARTIAL, USAGE
from setupfix.model import CANONICAL_COLUMNS

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
QIF = ROOT / "sample_reports" / "qif"
TABLES = ROOT / "sample_reports" / "tables"


def rows_of(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_parse_writes_the_canonical_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "all.csv"
    status = main(["parse", str(GUIDE / "cycle_01.qif"), str(GUIDE / "cycle_01.dmo"), "--out", str(out)])
    assert status == OK
    rows = rows_of(out)
    assert len(rows) == 56
    assert list(rows[0])[: len(CANONICAL_COLUMNS)] == list(CANONICAL_COLUMNS)
    assert rows[0]["characteristic"] == "P1 D1" and rows[0]["deviation"] == "-0.0309"
    assert rows[0]["lower"] == "-0.1" and rows[0]["station"] == "P1" and rows[0]["part"] == "cycle 01"
    assert {r["report"] for r in rows} == {"cycle_01.qif", "cycle_01.dmo"}
    assert "56 rows from 2 of 2 file(s)" in capsys.readouterr().err


def test_parse_to_stdout(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["parse", str(GUIDE / "cycle_01.csv"), "--out", "-"]) == OK
    rows = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert len(rows) == 28 and rows[27]["characteristic"] == "P4 D7"


def test_bad_file_is_named_and_the_others_still_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "broken.qif"
    bad.write_text('<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">\n<Results>\n', encoding="utf-8")
    out = tmp_path / "out.csv"
    status = main(["parse", str(bad), str(GUIDE / "cycle_01.dmo"), "--out", str(out)])
    assert status == PARTIAL
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith(f"error: {bad}:") and "not well-formed XML" in errors[0]
    assert len(rows_of(out)) == 28


def test_all_files_bad_exits_1_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out.csv"
    status = main(["parse", str(QIF / "QIF3_WIDGET_QIF_PLAN.QIF"), str(tmp_path / "absent.dmo"), "--out", str(out)])
    assert status == ERROR
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and "no measurement results" in err[0] and "cannot read" in err[1]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_warnings_are_one_line_each(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "nist.csv"
    assert main(["parse", str(QIF / "NIST_MTC_FAIR_Plate_Results_20parts.qif"), "--out", str(out)]) == OK
    err = capsys.readouterr().err
    assert "warning: " in err and "read as mm" in err and "Traceback" not in err
    assert len({r["part"] for r in rows_of(out)}) == 20


def test_unit_option_reaches_the_reader(tmp_path: Path) -> None:
    out = tmp_path / "o.csv"
    assert main(["parse", "--unit", "inch", str(QIF / "QIF3_Exploded_Results1.QIF"), "--out", str(out)]) == OK
    assert float(rows_of(out)[0]["nominal"]) == pytest.approx(25.4 * 25.4)


def test_columns_and_encoding_options(tmp_path: Path) -> None:
    out = tmp_path / "o.csv"
    status = main(
        [
            "parse",
            "--columns",
            str(TABLES / "cycle_01_shop.columns.toml"),
            str(TABLES / "cycle_01_shop.csv"),
            "--out",
            str(out),
        ]
    )
    assert status == OK and rows_of(out)[3]["deviation"] == "-0.0747"
    assert main(["parse", "--encoding", "cp1252", str(TABLES / "cycle_01_de.csv"), "--out", str(out)]) == OK
    assert rows_of(out)[0]["lower"] == "-0.1"


def test_unknown_format_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status = main(["parse", "--format", "nope", str(GUIDE / "cycle_01.csv"), "--out", str(tmp_path / "o.csv")])
    assert status == ERROR
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown format 'nope'" in err[0]


def test_out_is_required(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["parse", str(GUIDE / "cycle_01.csv")]) == USAGE


def test_formats_lists_readers(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["formats"]) == OK
    out = capsys.readouterr().out
    for name in ("qif", "dmis", "calypso", "table", "canonical"):
        assert any(line.split()[0] == name for line in out.splitlines()[1:])
    assert main(["formats", "--json"]) == OK
    listed = {f["name"]: f for f in json.loads(capsys.readouterr().out)}
    assert listed["qif"]["extensions"] == [".qif"]


@pytest.mark.slow
@pytest.mark.parametrize("suffix", ["qif", "dmo"])
def test_correct_accepts_qif_and_dmis(suffix: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["correct", "--model", str(GUIDE / "model.toml"), str(GUIDE / "cycle_01.csv"), "--json"]) == OK
    expected = json.loads(capsys.readouterr().out)
    assert main(["correct", "--model", str(GUIDE / "model.toml"), str(GUIDE / f"cycle_01.{suffix}"), "--json"]) == OK
    got = json.loads(capsys.readouterr().out)
    assert got["corrections"] == expected["corrections"] and got["margin_after"] == expected["margin_after"]


def test_a_folder_stands_for_its_reports(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = ROOT / "sample_reports" / "pcdmis"
    out = tmp_path / "all.csv"
    assert main(["parse", str(folder), "--out", str(out)]) == OK
    err = capsys.readouterr().err
    assert "README.md" not in err  # never a report: left out by the folder policy (parsers.folders)
    assert "from 3 of 3 file(s)" in err
    assert {r["report"] for r in rows_of(out)} == {
        "bracket_minus_negative.txt",
        "bracket_ncgage.csv",
        "bracket_two_parts.txt",
    }
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["parse", str(empty), "--out", str(tmp_path / "x.csv")]) == ERROR
    assert "folder holds no report file" in capsys.readouterr().err
