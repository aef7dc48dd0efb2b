"""CALYPSO ``*_chr.txt`` reader: header names, ragged rows, END line, Latin-1, checks."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import shared_path

import parsers
from parsers.calypso import read_calypso, sniff_calypso
from setupfix.core.errors import ParseError

HEADER = (
    "planid\tpartnb\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\texceed\t"
    "featurePosX\tfeaturePosY\tfeaturePosZ\tunit\tgroup1\tgroup2\t"
)


def write(tmp_path: Path, rows: list[str], *, end: bool = True, encoding: str = "cp1252") -> Path:
    path = tmp_path / "plan_chr.txt"
    path.write_bytes("\n".join([HEADER, *rows, *(["END"] if end else [])]).encode(encoding) + b"\n")
    return path


def test_sniffer_needs_the_calypso_header() -> None:
    assert sniff_calypso(HEADER + "\nx")
    assert not sniff_calypso("characteristic,nominal,actual\n")


def test_ragged_rows_latin1_and_end_line(tmp_path: Path) -> None:
    # Rows stop after `unit` (no group cells), as in the real file; "Lotlänge" is CP1252.
    path = write(
        tmp_path,
        [
            "Plan\t16\tDistanz Z 8mm\tLotlänge\tlengthOfAxis\t9.2153484\t8.0000000\t0.1\t-0.1\t"
            "1.2153484\t1.1153484\t2.45\t-0.49\t-4.61\tmm",
            "Plan\t16\tD 9\tDurchmesser\tdiameter\t8.9973025\t9\t0.1\t-0.1\t-0.0026975\t\t1\t2\t3\tmm",
        ],
    )
    assert parsers.find_format(path).name == "calypso"
    table = read_calypso(path)
    first = table.iloc[0]
    assert (first["characteristic"], first["nominal"], first["lower"], first["upper"]) == (
        "Distanz Z 8mm",
        8.0,
        -0.1,
        0.1,
    )
    assert first["deviation"] == pytest.approx(1.2153484) and first["status"] == "exceed 1.1153484"
    assert (first["part"], first["x"], first["source"].endswith("plan_chr.txt:2")) == ("16", 2.45, True)
    assert table.iloc[1]["status"] == ""


def test_columns_are_found_by_name_in_any_order(tmp_path: Path) -> None:
    path = tmp_path / "x_chr.txt"
    path.write_text("idsymbol\tnominal\tplanid\tactual\tid\nx\t5\tP\t5.01\tX1\nEND\n", encoding="utf-8")
    row = read_calypso(path).iloc[0]
    assert (row["characteristic"], row["nominal"], row["actual"]) == ("X1", 5.0, 5.01)


def test_inch_rows_and_decimal_commas(tmp_path: Path) -> None:
    path = write(tmp_path, ["P\t1\tA\tt\tdiameter\t1,001\t1,000\t0,002\t-0,002\t0,001\t\t\t\t\tinch"])
    row = read_calypso(path).iloc[0]
    assert row["nominal"] == pytest.approx(25.4) and row["upper"] == pytest.approx(0.0508)


def test_contradicting_deviation_names_the_line(tmp_path: Path) -> None:
    path = write(tmp_path, ["P\t1\tA\tt\tdiameter\t10.5\t10\t0.1\t-0.1\t0.2\t\t\t\t\tmm"])
    with pytest.raises(ParseError, match=r"plan_chr\.txt:2: deviation 0.2 mm contradicts"):
        read_calypso(path)


def test_bad_number_names_line_and_column(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            "P\t1\tA\tt\tdiameter\t10.0\t10\t0.1\t-0.1\t0\t\t\t\t\tmm",
            "P\t1\tB\tt\tdiameter\tn/a\t10\t0.1\t-0.1\t\t\t\t\t\tmm",
        ],
    )
    with pytest.raises(ParseError, match=r"plan_chr\.txt:3: column 'actual': expected a number, found 'n/a'"):
        read_calypso(path)


def test_missing_column_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bad_chr.txt"
    path.write_text("planid\tid\tidsymbol\tactual\tnominal_x\n", encoding="utf-8")
    with pytest.raises(ParseError, match="missing CALYPSO column"):
        read_calypso(path)


def test_real_sample_reads_with_its_out_of_tolerance_row() -> None:
    table = read_calypso(shared_path("cmm-samples", "calypso", "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt"))
    assert len(table) == 22 and set(table["part"]) == {"16"}
    oot = table[table["status"] != ""]
    assert list(oot["characteristic"]) == ["Distanz Z 8mm"]
    assert (table["unit"] == "mm").all()
