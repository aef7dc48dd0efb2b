"""Temperature-log reading: every bad input named by file and line."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.errors import ParseError, ParseWarning
from setupfix.thermal.data import read_temperature_log, select_columns

GOOD = (
    "timestamp,T1,T2,spindle_speed,error,operator\n"
    "2026-01-05T06:00:00,20.0,20.1,0,0.0,anna\n"
    "2026-01-05T06:00:10,20.5,20.2,1000,0.001,anna\n"
    "2026-01-05T06:00:20,21.0,,1000,0.002,\n"
)


def write(tmp_path, text, name="log.csv", bom=False):
    path = tmp_path / name
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return path


def test_reads_columns_times_and_gaps(tmp_path):
    log = read_temperature_log(write(tmp_path, GOOD, bom=True))
    assert list(log.columns) == ["T1", "T2", "spindle_speed", "error"]  # the text column is ignored
    np.testing.assert_allclose(log.seconds, [0, 10, 20])
    assert log.sample_interval_s == 10.0
    assert np.isnan(log.columns["T2"][2])
    with pytest.raises(ParseError, match=r"log\.csv:4: empty value in column 'T2'"):
        log.require_finite("T2")
    sel = select_columns(log, target="error")
    assert sel.inputs == ("T1", "T2") and sel.speed == "spindle_speed"


def test_non_numeric_temperature_names_the_line(tmp_path):
    rows = GOOD.splitlines()
    rows[2] = rows[2].replace("20.5", "hot")
    with pytest.raises(ParseError, match=r"log\.csv:3: non-numeric value 'hot' in column 'T1'"):
        read_temperature_log(write(tmp_path, "\n".join(rows) + "\n"))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda r: r.__setitem__(0, r[0].replace("timestamp", "time")), r":1: no 'timestamp' column"),
        (lambda r: r.__setitem__(3, r[3].replace("2026-01-05T06:00:20", "yesterday")), r":4: timestamp 'yesterday'"),
        (lambda r: r.__setitem__(3, r[3].replace("06:00:20", "06:00:05")), r":4: timestamp not after"),
        (lambda r: r.__setitem__(2, r[2] + ",extra,cell"), r":3: 8 cells but 6 columns"),
    ],
)
def test_structural_errors(tmp_path, edit, message):
    rows = GOOD.splitlines()
    edit(rows)
    with pytest.raises(ParseError, match=message):
        read_temperature_log(write(tmp_path, "\n".join(rows) + "\n"))


def test_empty_and_missing_files(tmp_path):
    with pytest.raises(ParseError, match="empty file"):
        read_temperature_log(write(tmp_path, ""))
    with pytest.raises(ParseError, match="no data rows"):
        read_temperature_log(write(tmp_path, "timestamp,T1\n"))
    with pytest.raises(ParseError, match="cannot read"):
        read_temperature_log(tmp_path / "absent.csv")


def test_selection_errors(tmp_path):
    log = read_temperature_log(write(tmp_path, GOOD))
    with pytest.raises(ParseError, match="target column 'E'"):
        select_columns(log, target="E")
    with pytest.raises(ParseError, match="ambient"):
        select_columns(log, target="error", need_ambient=True)
    with pytest.raises(ParseError, match="input column 'T9'"):
        select_columns(log, target="error", inputs=["T9"])


def test_irregular_sampling_warns(tmp_path):
    text = GOOD.replace("06:00:20", "06:01:20")
    with pytest.warns(ParseWarning, match="sampling interval varies"):
        read_temperature_log(write(tmp_path, text))
