"""Temperature-log reading: every bad input named by file and line; logs as shops have them."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from parsers.temperature import read_temperature_log
from setupfix.core.errors import ParseError
from setupfix.thermal.columns import select_columns

GOOD = (
    "timestamp,T1,T2,spindle_speed,error,operator\n"
    "2026-01-05T06:00:00,20.0,20.1,0,0.0,anna\n"
    "2026-01-05T06:00:10,20.5,20.2,1000,0.001,anna\n"
    "2026-01-05T06:00:20,21.0,,1000,0.002,\n"
)


def write(tmp_path: Path, text: str, name: str = "log.csv", bom: bool = False) -> Path:
    path = tmp_path / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return path


def test_reads_columns_times_and_gaps(tmp_path: Path) -> None:
    log = read_temperature_log(write(tmp_path, GOOD, bom=True))
    assert list(log.columns) == ["T1", "T2", "spindle_speed", "error"]  # the text column is ignored…
    assert any("'operator' is text" in str(n) for n in log.notes)  # …and said so
    assert log.seconds is not None
    np.testing.assert_allclose(log.seconds, [0, 10, 20])
    assert log.sample_interval_s == 10.0
    assert np.isnan(log.columns["T2"][2])
    with pytest.raises(ParseError, match=r"log\.csv:4: empty value in column 'T2'"):
        log.require_finite("T2")
    sel = select_columns(log, target="error")
    assert sel.inputs == ("T1", "T2")


@pytest.mark.parametrize("cell", ["hot", "2_1", "nan", "inf", "1,5", "0x10"])
def test_non_numbers_are_refused_with_the_line(tmp_path: Path, cell: str) -> None:
    rows = GOOD.splitlines()
    rows[2] = rows[2].replace("20.5", f'"{cell}"')
    with pytest.raises(ParseError, match=rf"log\.csv:3: non-numeric value '{cell}' in column 'T1'"):
        read_temperature_log(write(tmp_path, "\n".join(rows) + "\n"))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda r: r.__setitem__(0, r[0].replace("timestamp", "time")), r":1: no 'timestamp' column.*--interval"),
        (lambda r: r.__setitem__(3, r[3].replace("2026-01-05T06:00:20", "yesterday")), r":4: timestamp 'yesterday'"),
        (lambda r: r.__setitem__(3, r[3].replace("06:00:20", "06:00:05")), r":4: timestamp not after"),
        (lambda r: r.__setitem__(2, r[2] + ",extra,cell"), r":3: 8 cells but 6 columns"),
        (lambda r: r.__setitem__(0, r[0].replace("T2", "t1")), r":1: column 't1' appears twice \(columns 2 and 3\)"),
        (
            lambda r: r.__setitem__(2, r[2].replace("20.5", "9" * 140_000)),
            r"log\.csv:\d+: unreadable line: field larger than field limit",
        ),
    ],
)
def test_structural_errors(tmp_path: Path, edit: Callable[[list[str]], object], message: str) -> None:
    rows = GOOD.splitlines()
    edit(rows)
    with pytest.raises(ParseError, match=message):
        read_temperature_log(write(tmp_path, "\n".join(rows) + "\n"))


def test_empty_and_missing_files(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match="empty file"):
        read_temperature_log(write(tmp_path, ""))
    with pytest.raises(ParseError, match="no data rows"):
        read_temperature_log(write(tmp_path, "timestamp,T1\n"))
    with pytest.raises(ParseError, match="cannot read"):
        read_temperature_log(tmp_path / "absent.csv")


def test_interval_and_sample_index(tmp_path: Path) -> None:
    text = "T1,T2,E\n20,20,0\n21,20.5,1\n22,21,2\n"
    with pytest.raises(ParseError, match="no 'timestamp' column"):
        read_temperature_log(write(tmp_path, text))
    log = read_temperature_log(write(tmp_path, text), interval=30)
    np.testing.assert_array_equal(log.seconds, [0, 30, 60])
    indexed = read_temperature_log(write(tmp_path, "sample,T1,E\n5,20,0\n6,21,1\n8,22,2\n"), interval=30)
    np.testing.assert_array_equal(indexed.seconds, [0, 30, 90])
    assert "sample" not in indexed.columns
    counted = read_temperature_log(write(tmp_path, "sample,T1,E\n5,20,0\n6,21,1\n"))
    assert counted.seconds is None and any("time counted in samples" in str(n) for n in counted.notes)
    with pytest.raises(ParseError, match="positive number of seconds"):
        read_temperature_log(write(tmp_path, text), interval=-1)


def test_xlsx_log_without_header(tmp_path: Path) -> None:
    openpyxl = pytest.importorskip("openpyxl")
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.title = "run1"
    for row in ([0.0, 0.0, 0.0], [0.5, 0.1, 1.1], [0.9, 0.3, 2.0]):
        sheet.append(row)
    book.save(tmp_path / "log.xlsx")
    log = read_temperature_log(tmp_path / "log.xlsx", interval=60)
    assert list(log.columns) == ["A", "B", "C"]
    np.testing.assert_array_equal(log.columns["C"], [0.0, 1.1, 2.0])
    np.testing.assert_array_equal(log.seconds, [0, 60, 120])
    sheet.append(["warm", 0.4, 2.5])
    book.save(tmp_path / "bad.xlsx")
    with pytest.raises(ParseError, match=r"bad\.xlsx: <run1!4>: non-numeric value 'warm' in column 'A'"):
        read_temperature_log(tmp_path / "bad.xlsx", interval=60)


def test_irregular_sampling_is_noted(tmp_path: Path) -> None:
    log = read_temperature_log(write(tmp_path, GOOD.replace("06:00:20", "06:01:20")))
    assert any("sampling interval varies" in str(n) for n in log.notes)


# -- one reader behind every door: history import, diagnose ---------------------------------------

_GUIDE = __import__("pathlib").Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"
_TEMPS = "timestamp,spindle\n2026-11-02T06:00:00,20.1\n\n"


@pytest.mark.parametrize(
    ("row", "message"),
    [
        ("yesterday,20.2", "timestamp 'yesterday' is not ISO 8601"),
        ("2026-11-02T07:00:00,2_0", "non-numeric value '2_0' in column 'spindle'"),
        ("2026-11-02T07:00:00,20.2,21", "3 cells but 2 columns in the header"),
        ("2026-11-02T05:00:00,20.2", "timestamp not after the previous one"),
    ],
)
def test_a_bad_temperature_row_is_named_alike_by_history_import_and_diagnose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], row: str, message: str
) -> None:
    from setupfix.cli import main

    log = write(tmp_path, _TEMPS + row + "\n")  # the bad row is line 4
    reports = [str(p) for p in sorted(_GUIDE.glob("cycle_0*.csv"))]
    errors = []
    for argv in (
        ["history", "import", "--db", str(tmp_path / "h.db"), "--temperatures", str(log), *reports],
        ["diagnose", "--model", str(_GUIDE / "model.toml"), "--no-walk", "--temperatures", str(log), *reports],
    ):
        assert main(argv) == 1
        errors.append(capsys.readouterr().err)
    assert errors[0] == errors[1] and errors[0].startswith(f"error: {log}:4: {message}")
