"""A process log joined per cycle: by timestamp or serial, numeric and categorical channels, clear refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import GUIDE_PINS, SAMPLES

from parsers.temperature import read_temperature_log
from setupfix.core.errors import MatchError, ParseError
from setupfix.inputs.series import load_series

LOOP = SAMPLES / "closed_loop"
REPORT = LOOP / "measurements.csv"


def _cycles() -> list[tuple[str, str]]:
    import pandas as pd

    t = pd.read_csv(REPORT)
    return sorted(set(zip(t["timestamp"], t["part"], strict=True)))


def test_text_columns_kept_only_when_asked(tmp_path: Path) -> None:
    f = tmp_path / "p.csv"
    f.write_text("serial,rpm,batch\n1,9000,A\n2,6000,B\n", encoding="utf-8")
    assert "batch" not in read_temperature_log(f, require_time=False).columns
    log = read_temperature_log(f, require_time=False, keep_text=True)
    assert log.text == {"batch": ["A", "B"]} and log.columns["rpm"].tolist() == [9000.0, 6000.0]


def test_joined_by_timestamp_at_or_before_each_part(tmp_path: Path) -> None:
    cycles = _cycles()
    rows = ["timestamp,feed,insert"]
    for i, (stamp, _) in enumerate(cycles):
        rows.append(f"{stamp},{100 + i},{'new' if i >= 10 else 'old'}")
    f = tmp_path / "process.csv"
    f.write_text("\n".join(rows) + "\n", encoding="utf-8")
    s = load_series(GUIDE_PINS / "model.toml", (REPORT,), process=str(f)).series
    assert s.process_channels == ("feed", "insert=new")  # two levels: one indicator
    np.testing.assert_array_equal(s.temperature[:, 0], 100 + np.arange(len(cycles)))
    assert s.temperature[:, 1].tolist() == [0.0] * 10 + [1.0] * (len(cycles) - 10)


def test_joined_by_serial_and_a_missing_part_is_named(tmp_path: Path) -> None:
    cycles = _cycles()
    f = tmp_path / "process.csv"
    f.write_text(
        "serial,rpm\n" + "".join(f"{p},{6000 + 100 * i}\n" for i, (_, p) in enumerate(cycles)), encoding="utf-8"
    )
    s = load_series(GUIDE_PINS / "model.toml", (REPORT,), process=str(f)).series
    np.testing.assert_array_equal(s.temperature[:, 0], 6000 + 100 * np.arange(len(cycles)))
    f.write_text("serial,rpm\n" + "".join(f"{p},1\n" for _, p in cycles[1:]), encoding="utf-8")
    with pytest.raises(MatchError, match=f"part {cycles[0][1]} has no row in the process log"):
        load_series(GUIDE_PINS / "model.toml", (REPORT,), process=str(f))
    f.write_text("serial,rpm\n" + "".join(f"{p},1\n" for _, p in cycles) + f"{cycles[0][1]},2\n", encoding="utf-8")
    with pytest.raises(ParseError, match="appears twice"):
        load_series(GUIDE_PINS / "model.toml", (REPORT,), process=str(f))


def test_a_log_without_serial_or_timestamp_is_refused(tmp_path: Path) -> None:
    f = tmp_path / "process.csv"
    f.write_text("rpm\n1\n2\n", encoding="utf-8")
    with pytest.raises(ParseError, match="'serial' column"):
        load_series(GUIDE_PINS / "model.toml", (REPORT,), process=str(f))
