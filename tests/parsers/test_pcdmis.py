"""PC-DMIS text report and CSV readers on the constructed fixtures (sample_reports/pcdmis/README.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from goldens import GOLDEN, assert_golden, expect_note

import parsers
from parsers.pcdmis import read_pcdmis_csv, read_pcdmis_text
from setupfix.core.errors import ParseError
from setupfix.model.measurements import ACTUAL_POSITION_COLUMNS

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "pcdmis"


@pytest.mark.parametrize(
    "name, fmt",
    [
        ("bracket_two_parts.txt", "pcdmis"),
        ("bracket_minus_negative.txt", "pcdmis"),
        ("bracket_ncgage.csv", "pcdmis-csv"),
    ],
)
def test_fixture_matches_golden(name: str, fmt: str, tmp_path: Path) -> None:
    assert parsers.find_format(SAMPLES / name).name == fmt
    table = parsers.read_report(SAMPLES / name).table
    golden = GOLDEN / f"pcdmis_{Path(name).stem}.csv"
    # the measured location (issue 39) is numeric: compared as numbers here, the rest by assert_golden
    want = pd.read_csv(golden, keep_default_na=False, dtype=str)
    for col in ACTUAL_POSITION_COLUMNS:
        expected = pd.to_numeric(want[col].replace("", np.nan)).to_numpy(float)
        np.testing.assert_allclose(table[col].to_numpy(float), expected, atol=1e-9, equal_nan=True, err_msg=col)
    stripped = tmp_path / golden.name
    want.drop(columns=list(ACTUAL_POSITION_COLUMNS)).to_csv(stripped, index=False)
    assert_golden(table.drop(columns=list(ACTUAL_POSITION_COLUMNS)), stripped, str(SAMPLES) + "/")


def test_minus_tolerance_magnitude_and_signed_read_alike() -> None:
    magnitude = read_pcdmis_text(SAMPLES / "bracket_two_parts.txt")
    signed = read_pcdmis_text(SAMPLES / "bracket_minus_negative.txt")
    first = magnitude[magnitude["part"] == "0041"].reset_index(drop=True)
    cols = ["characteristic", "nominal", "actual", "lower", "upper"]
    pd.testing.assert_frame_equal(first[cols], signed[cols])
    # LOC2.Z is UNITS=IN: -0.5000 in, +0.0010/-0.0030 in.
    z = first.set_index("characteristic").loc["LOC2.Z"]
    assert (z["nominal"], z["lower"], z["upper"]) == pytest.approx((-12.7, -0.0762, 0.0254))


def test_two_parts_angles_skipped_with_lines() -> None:
    with expect_note(r"skipped 2 angle characteristic\(s\).*line 27, 61"):
        table = read_pcdmis_text(SAMPLES / "bracket_two_parts.txt")
    assert table.groupby("part").size().to_dict() == {"0041": 7, "0042": 7}
    assert table.loc[table["characteristic"] == "TP1.TP", "lower"].isna().all()
    assert table.loc[2, "status"] == "out" and table.loc[0, "status"] == "ok"


def test_csv_timestamp_serial_and_form_rows() -> None:
    with expect_note():
        table = read_pcdmis_csv(SAMPLES / "bracket_ncgage.csv")
    assert set(table["timestamp"]) == {"2025-03-14T09:41:07"} and set(table["part"]) == {"0044"}
    assert "CIR1.Angle" not in set(table["characteristic"])


def _edit(tmp_path: Path, old: str, new: str) -> Path:
    text = (SAMPLES / "bracket_two_parts.txt").read_text()
    assert old in text
    path = tmp_path / "edited.txt"
    path.write_text(text.replace(old, new, 1))
    return path


def test_contradicting_deviation_names_the_line(tmp_path: Path) -> None:
    path = _edit(tmp_path, "50.0123     0.0123", "50.0123     0.0223")
    with pytest.raises(ParseError, match=r"edited\.txt:7: stated deviation"):
        read_pcdmis_text(path)


def test_contradicting_outtol_names_the_line(tmp_path: Path) -> None:
    path = _edit(tmp_path, "12.0264     0.0264     0.0064", "12.0264     0.0264     0.0000")
    with pytest.raises(ParseError, match=r"edited\.txt:9: OUTTOL"):
        read_pcdmis_text(path)


def test_unknown_units_and_garbage_number(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match=r":4: unknown UNITS=FT"):
        read_pcdmis_text(_edit(tmp_path, "UNITS=MM ,$", "UNITS=FT ,$"))
    with pytest.raises(ParseError, match=r":8: MEAS: expected a number"):
        read_pcdmis_text(_edit(tmp_path, "29.9712", "29.97x2"))


def test_csv_column_reader_equals_row_reader() -> None:
    from parsers.pcdmis.columns import read_columns
    from parsers.pcdmis.csv_export import read_rows
    from parsers.source import read_text as read_report_text

    name = str(SAMPLES / "bracket_ncgage.csv")
    text = read_report_text(name)
    columns = read_columns(text, name, None)
    assert columns is not None
    pd.testing.assert_frame_equal(columns, read_rows(text, name, None))


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('"29.9811"', '"29.98x1"', r"bad\.csv:8: MEAS: expected a number"),
        ('"-.0189"', '"-.0289"', r"bad\.csv:8: stated deviation"),
        ('".0030"', '".0000"', r"bad\.csv:9: OUTTOL"),
    ],
)
def test_csv_errors_name_the_line(tmp_path: Path, old: str, new: str, message: str) -> None:
    # A blank line is inserted after line 6, so the edited rows 7 and 8 become lines 8 and 9.
    lines = (SAMPLES / "bracket_ncgage.csv").read_text().replace(old, new, 1).splitlines()
    path = tmp_path / "bad.csv"
    path.write_text("\n".join([*lines[:6], "", *lines[6:]]) + "\n")
    with pytest.raises(ParseError, match=message):
        read_pcdmis_csv(path)
