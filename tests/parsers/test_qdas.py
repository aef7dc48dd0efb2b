"""Q-DAS AQDEF reader on the copied public samples (MIT / Apache-2.0), against golden tables."""

from __future__ import annotations

from pathlib import Path

import pytest
from goldens import GOLDEN, assert_golden, expect_note

import parsers
from parsers.qdas import read_aqdef
from setupfix.core.errors import ParseError
from setupfix.model.measurements import CANONICAL_COLUMNS

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "qdas"


@pytest.mark.parametrize(
    "name",
    [
        "diribet_basicDfq_singlePart_threeCharacteristics.dfq",
        "diribet_basicDfq_threeParts_differentNumberOfCharacteristics.dfq",
        "successfactory_testmeasures.dfq",
    ],
)
def test_sample_matches_golden(name: str) -> None:
    table = parsers.read_report(SAMPLES / name).table
    assert tuple(table.columns[: len(CANONICAL_COLUMNS)]) == CANONICAL_COLUMNS
    assert_golden(table, GOLDEN / f"qdas_{Path(name).stem}.csv", str(SAMPLES) + "/")


def test_value_lines_0x0f_0x14_and_cm_to_mm() -> None:
    with expect_note(r"without nominal \(K2101\): line 173, 180, 187, 194, 201"):
        table = read_aqdef(SAMPLES / "successfactory_testmeasures.dfq")
    # K2142 cm: 2.49960000000000E+0002 cm is 2499.6 mm; K2110/K2111 200/300 cm absolute → ±500 mm.
    first = table.iloc[0]
    assert first["actual"] == pytest.approx(2499.6) and first["nominal"] == pytest.approx(2500.0)
    assert (first["lower"], first["upper"]) == (pytest.approx(-500.0), pytest.approx(500.0))
    assert first["timestamp"] == "2002-05-17T05:54:58"
    assert table["part"].tolist() == [f"Teil 123.456.789#{n}" for n in range(1, 6)]


def test_multi_part_file_gives_one_part_per_piece() -> None:
    with expect_note("no length unit stated"):
        table = read_aqdef(SAMPLES / "diribet_basicDfq_threeParts_differentNumberOfCharacteristics.dfq")
    assert table.groupby("part").size().to_dict()["<part_number_2>#1"] == 3
    assert table["part"].nunique() == 8 + 1 + 3


def test_attributive_file_is_refused_with_reason() -> None:
    with pytest.raises(ParseError, match=r"attributive characteristic\(s\) without variable values \(K2004=1\)"):
        parsers.read_report(SAMPLES / "diribet_attributiveDfq_attributiveCharacteristic_and_errorLogSheet.dfq").table


@pytest.mark.parametrize("name", ["j4ggr_2604020002.dfd", "j4ggr_2604020002.dfx"])
def test_dfd_dfx_pair_of_forces_is_refused(name: str) -> None:
    # Force 1/2 are in N and "Meas ID" is an error-log characteristic: nothing is a length.
    with pytest.raises(
        ParseError, match=r"2 value\(s\) in a non-length unit \(K2142=N\) \(line (j4ggr_2604020002\.dfx:)?1, "
    ):
        read_aqdef(SAMPLES / name)


def test_dfd_dfx_pair_is_read_together(tmp_path: Path) -> None:
    (tmp_path / "p.dfd").write_text(
        "K0100 1\nK1001 P-1\nK2002/1 Bore\nK2101/1 10,0\nK2112/1 -0,02\nK2113/1 0,03\nK2142/1 mm\n"
    )
    (tmp_path / "p.dfx").write_bytes(b"10,012\x14\x14" + b"01.02.2024/08:00:00\x14\x14\x14\x14\r\n9,99\r\n")
    table = read_aqdef(tmp_path / "p.dfx")
    assert table["deviation"].round(6).tolist() == [0.012, -0.01]
    assert table[["lower", "upper"]].iloc[0].tolist() == pytest.approx([-0.02, 0.03])
    assert table["source"].tolist() == [f"{tmp_path}/p.dfx:1", f"{tmp_path}/p.dfx:2"]
    assert table["timestamp"].tolist() == ["2024-02-01T08:00:00", ""]


def test_slash_zero_applies_to_all_characteristics_and_explicit_wins(tmp_path: Path) -> None:
    path = tmp_path / "z.dfq"
    path.write_text(
        "K0100 2\nK2142/0 mm\nK2110/0 0\nK2001/1 A\nK2101/1 1\nK2001/2 B\nK2101/2 2\n"
        "K2110/2 1.5\nK0001/1 1.1\nK0001/2 2.1\n"
    )
    table = read_aqdef(path)
    assert table["lower"].tolist() == pytest.approx([-1.0, -0.5])


def test_contradicting_allowance_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "c.dfq"
    path.write_text("K0100 1\nK2001/1 A\nK2101/1 1\nK2142/1 mm\nK2111/1 1.1\nK2113/1 0.3\nK0001/1 1.05\n")
    with pytest.raises(ParseError, match=r"c\.dfq:6: K2113 allowance contradicts"):
        read_aqdef(path)


@pytest.mark.parametrize(
    "text",
    [
        "K0100 1\nK2001/1 A\nK0001/1 1\ngarbage here\n",
        "K0001 3\n",
        "K0100 1\nK2101/1 abc\nK0001/1 1\nK2142/1 mm\n",
        "K0001/7 1.0\n",
    ],
)
def test_garbage_raises_parse_error(tmp_path: Path, text: str) -> None:
    path = tmp_path / "g.dfq"
    path.write_text(text)
    with pytest.raises(ParseError):
        read_aqdef(path)


def test_dfd_with_dfb_values_reads_like_the_dfq(tmp_path: Path) -> None:
    """A .dfd description with its .dfb values (issue 14) reads as the same report in one .dfq."""
    dfq = SAMPLES / "diribet_basicDfq_singlePart_threeCharacteristics.dfq"
    lines = dfq.read_text().splitlines(keepends=True)
    (tmp_path / "run.dfd").write_text("".join(x for x in lines if not x.startswith(("K0001", "K0004"))))
    (tmp_path / "run.DFB").write_text("".join(x for x in lines if x.startswith(("K0001", "K0004"))))
    want = parsers.read_report(dfq).table
    for given in ("run.dfd", "run.DFB"):
        got = parsers.read_report(tmp_path / given)
        assert got.format == "qdas"
        assert got.table[["characteristic", "nominal", "actual", "lower", "upper"]].equals(
            want[["characteristic", "nominal", "actual", "lower", "upper"]]
        )
