"""Korean CMM text reader on the CP949 samples (no licence: used from ../shared, not copied).

Goldens hold derived numbers only (line, part number, values, limits, status).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from conftest import SAMPLES
from conftest import SHARED as SHARED_ROOT
from goldens import GOLDEN, assert_derived_golden, read_warned

import parsers
from parsers.korean import read_korean
from parsers.korean.report import along_normal
from setupfix.core.errors import ParameterError, ParseError

SHARED = SHARED_ROOT / "cmm-samples" / "korean_cmm_txt"
NAMES = sorted(p.name for p in SHARED.glob("KR_*.txt")) or ["KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt"]


def shared(name: str) -> Path:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): unlicensed sample not redistributed")
    return path


@pytest.mark.parametrize("name", NAMES)
def test_sample_matches_derived_golden(name: str) -> None:
    path = shared(name)
    assert parsers.find_format(path).name == "korean"
    table = parsers.read_report(path).table
    assert_derived_golden(table, GOLDEN / f"korean_{name.split('.')[0]}.csv")


def test_ng_report_out_of_tolerance_and_sign_quirk() -> None:
    table, _messages = read_warned(read_korean, shared("KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt"))
    row = table[table["source"].str.endswith(":31")].iloc[0]  # X 116.728, nominal 116.600, +0.100/0.000, excess 0.028
    assert (row["deviation"], row["lower"], row["upper"], row["status"]) == (pytest.approx(0.128), 0.0, 0.1, "out")
    assert table["timestamp"].iloc[0] == "2024-01-13T22:55:39"
    # Line 32: "Y -10.912, nominal 10.900, deviation 0.012": the nominal and the deviation are along
    # the plane's normal, which points to -Y; in Y the nominal is -10.9 and the deviation -0.012.
    row = table[table["source"].str.endswith(":32")].iloc[0]
    assert (row["nominal"], row["actual"], row["deviation"]) == (-10.9, -10.912, pytest.approx(-0.012))


@pytest.mark.parametrize(
    ("nominal", "actual", "stated", "limits", "expected"),
    [
        (5.0, 5.1, 0.1, (-0.1, 0.2), (5.0, -0.1, 0.2)),  # normal along the axis: as written
        (-2.4, -2.5, 0.1, (-0.1, 0.2), (-2.4, -0.2, 0.1)),  # reversed normal: limits mirrored
        (10.9, -10.912, 0.012, (-0.1, 0.2), (-10.9, -0.2, 0.1)),  # nominal also along the reversed normal
        (5.0, 5.1, 0.3, (-0.1, 0.2), None),  # contradicts itself
    ],
)
def test_deviation_along_the_feature_normal(
    nominal: float, actual: float, stated: float, limits: tuple[float, float], expected: float | None
) -> None:
    assert along_normal(nominal, actual, stated, *limits) == (pytest.approx(expected) if expected else None)


def test_lenient_skips_a_self_contradicting_row_with_its_line(tmp_path: Path) -> None:
    lines = shared("KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt").read_bytes().decode("cp949").split("\n")
    assert "0.012" in lines[31]
    lines[31] = lines[31].replace("0.012", "0.512")
    path = tmp_path / "bad.txt"
    path.write_bytes("\n".join(lines).encode("cp949"))
    with pytest.raises(ParseError, match=r"bad\.txt:32: stated deviation 0.512 mm fits neither"):
        parsers.read_report(path)
    result = parsers.read_report(path, lenient=True)
    assert not result.table["source"].str.endswith(":32").any()
    assert any(
        "contradicting themselves" in n.message and n.location is not None and n.location.line == 32
        for n in result.notes
    )


def test_second_part_suffix_gives_second_part() -> None:
    table = read_korean(shared("KR_45926-4G100_240321_day_1-2-1_OK.cp949.txt"))
    parts = table["part"].unique().tolist()
    assert len(parts) == 2 and parts[1] == parts[0] + "#2"
    first, second = (set(table.loc[table["part"] == p, "characteristic"]) for p in parts)
    assert len(first & second) >= 20  # "원1#2(I)" is named like "원1(I)" so both match one dimension


def test_encoding_sniffed_and_override(tmp_path: Path) -> None:
    path = shared("KR_45926-4G400_230312_day_1-1-1_NG.cp949.txt")
    utf8 = tmp_path / "utf8.txt"
    utf8.write_text(path.read_bytes().decode("cp949"), encoding="utf-8")
    a, b = read_korean(path), read_korean(utf8, encoding="utf-8")
    pd.testing.assert_frame_equal(a.drop(columns=["source", "report"]), b.drop(columns=["source", "report"]))
    with pytest.raises(ParseError, match="bytes are not utf-8 text"):
        read_korean(path, encoding="utf-8")


def test_misplaced_value_names_the_line(tmp_path: Path) -> None:
    lines = shared("KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt").read_bytes().decode("cp949").split("\n")
    lines[12] = lines[12].replace("16.497", "16,4x7")
    path = tmp_path / "bad.txt"
    path.write_bytes("\n".join(lines).encode("cp949"))
    with pytest.raises(ParseError, match=r"bad\.txt:13: 측정값: expected a number"):
        read_korean(path)


@pytest.mark.parametrize("name", ["cycle_01.csv", "cycle_01.qif", "cycle_01.dmo"])
def test_lenient_is_ignored_by_a_reader_that_never_skips_a_row(name: str) -> None:
    """``--lenient`` only relaxes: a reader without self-contradicting rows reads the same with it
    (``batch --lenient`` over a folder of mixed formats); an option that changes numbers is still refused."""
    path = SAMPLES / "guide_pins" / name
    plain = parsers.read_report(path)
    lenient = parsers.read_report(path, lenient=True)
    assert lenient.format == plain.format != "korean"
    pd.testing.assert_frame_equal(lenient.table, plain.table)
    if name.endswith(".qif"):  # an option that would change numbers is still refused by a reader without it
        with pytest.raises(ParameterError, match="does not use --encoding"):
            parsers.read_report(path, encoding="cp949")
