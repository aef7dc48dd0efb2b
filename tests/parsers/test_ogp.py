"""OGP reader on the JLab survey reports (GPL-3.0, used from ../shared, not copied).

Goldens hold derived numbers only (line, part number, values, limits, status), not the
files' text.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED as SHARED_ROOT
from goldens import GOLDEN, assert_derived_golden, read_warned

import parsers
from parsers.ogp import read_ogp
from parsers.ogp.rtf import rtf_lines
from setupfix.core.errors import ParseError

SHARED = SHARED_ROOT / "cmm-samples" / "ogp_measurex"


def shared(name: str) -> Path:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): GPL sample not redistributed")
    return path


NAMES = [
    "OGP_L0_axial_top_module1_1.rtf.txt",
    "OGP_L123_fixture_sho_multirun.txt",
    "OGP_empty_fixture0.txt",
    "OGP_transitionPlate_ogp_coords.txt",
    "OGP_uchannel_empty_bottom_1.rtf.txt",
]


@pytest.mark.parametrize("name", NAMES)
def test_sample_matches_derived_golden(name: str) -> None:
    path = shared(name)
    assert parsers.find_format(path).name == "ogp"
    table = parsers.read_report(path).table
    assert_derived_golden(table, GOLDEN / f"ogp_{name.split('.')[0]}.csv")


def test_rtf_unwrapping_keeps_line_numbers() -> None:
    path = shared("OGP_L0_axial_top_module1_1.rtf.txt")
    raw = path.read_bytes().decode("cp1252").split("\n")
    lines = rtf_lines("\n".join(raw))
    assert len(lines) == len(raw)
    assert lines[2].startswith("C:\\Documents and Settings\\Administrator")  # "\\\\" unescaped
    assert all("\\" not in line[:2] and "{" not in line for line in lines)


def test_step_report_skips_taught_rows_and_keeps_measured_ones() -> None:
    table, messages = read_warned(read_ogp, shared("OGP_L0_axial_top_module1_1.rtf.txt"))
    assert "skipped 96 row(s) with nominal = actual and no tolerance" in messages
    first = table.iloc[1]  # Step 1 X Location: +309.57221 measured, +309.54829 nominal, line 17
    assert first["source"].endswith(":17")
    assert (first["actual"], first["nominal"]) == pytest.approx((309.57221, 309.54829))
    assert np.isnan(first["lower"]) and np.isnan(first["upper"])  # +00.00000 -00.00000: no tolerance


def test_run_table_parts_timestamps_and_magnitude_deviation() -> None:
    table, messages = read_warned(read_ogp, shared("OGP_L123_fixture_sho_multirun.txt"))
    assert "no length unit stated" in messages and "skipped 156 angle row(s)" in messages
    assert table["part"].nunique() == 13
    assert table["timestamp"].iloc[0] == "2014-10-01T17:29:15"
    row = table[table["source"].str.endswith(":31")].iloc[0]  # Y -113.895 -> -113.903, stated +0.009
    assert row["deviation"] == pytest.approx(-0.008)


def test_contradicting_deviation_is_refused_with_line(tmp_path: Path) -> None:
    text = shared("OGP_L123_fixture_sho_multirun.txt").read_bytes().decode("ascii").split("\r\n")
    assert text[30].startswith("Y Location     -00113.895 -00113.903        +00000.009")
    text[30] = text[30].replace("+00000.009", "+00000.090")
    path = tmp_path / "bad.txt"
    path.write_bytes("\r\n".join(text).encode("ascii"))
    with pytest.raises(ParseError, match=r"bad\.txt:31: stated deviation"):
        read_ogp(path)
