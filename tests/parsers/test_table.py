"""Shop tables: CSV/Excel through a column mapping, guessed headers, locales, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import openpyxl
import pandas as pd
import pytest

import parsers
from parsers.table import guess_columns, parse_columns, read_table
from setupfix.core.errors import ParseError

ROOT = Path(__file__).resolve().parents[2]
TABLES = ROOT / "sample_reports" / "tables"
CSV = ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv"


def same_as_canonical(table: pd.DataFrame) -> None:
    ref = parsers.read_report(CSV).table
    assert list(table["characteristic"]) == list(ref["characteristic"])
    assert np.allclose(table["deviation"], ref["deviation"], atol=1e-12)
    assert np.allclose(table["lower"], ref["lower"]) and np.allclose(table["upper"], ref["upper"])
    assert list(table["station"]) == list(ref["station"]) and list(table["part"]) == list(ref["part"])


def test_parse_columns_forms(tmp_path: Path) -> None:
    assert parse_columns("actual=Meas, nominal=Nom") == {"actual": "Meas", "nominal": "Nom"}
    mapping = tmp_path / "m.txt"
    mapping.write_text('# shop A\nactual = Meas\nnominal = "Nom"\n', encoding="utf-8")
    assert parse_columns(str(mapping)) == {"actual": "Meas", "nominal": "Nom"}
    with pytest.raises(ParseError, match="unknown column key"):
        parse_columns("actuel=Meas")
    with pytest.raises(ParseError, match="expected KEY=HEADER"):
        parse_columns("actual=Meas,nominal")


def test_guess_columns_knows_common_spellings_and_leaves_ambiguity() -> None:
    guessed = guess_columns(["Merkmal", "Sollwert", "Istwert", "UGW", "OGW"], {})
    assert guessed == {
        "characteristic": "Merkmal",
        "nominal": "Sollwert",
        "actual": "Istwert",
        "lsl": "UGW",
        "usl": "OGW",
    }
    assert "actual" not in guess_columns(["Name", "Nom", "Meas", "Measured"], {})


def test_german_export_semicolons_decimal_commas_cp1252() -> None:
    table = parsers.read_report(TABLES / "cycle_01_de.csv").table
    same_as_canonical(table)
    assert table["source"].iloc[0].endswith("cycle_01_de.csv:2")


def test_mapping_file_completes_the_guess() -> None:
    table = parsers.read_report(TABLES / "cycle_01_shop.csv", columns=str(TABLES / "cycle_01_shop.columns.toml")).table
    same_as_canonical(table)


def test_without_mapping_unknown_headers_are_refused_with_hint() -> None:
    with pytest.raises(ParseError, match=r"cycle_01_shop.csv:1: no column for characteristic.*--columns"):
        read_table(TABLES / "cycle_01_shop.csv")


@pytest.fixture(params=["calamine", "openpyxl"])
def excel_engine(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run an Excel test with python-calamine, and again with the openpyxl fallback."""
    if request.param == "openpyxl":
        import sys

        monkeypatch.setitem(sys.modules, "python_calamine", None)  # import now raises ImportError
    return str(request.param)


def test_excel_workbook_with_cell_provenance(tmp_path: Path, excel_engine: str) -> None:
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.title = "CMM"
    sheet.append(["Results of cycle 1"])
    sheet.append([])
    sheet.append(["Name", "Nom", "Meas", "Tol"])
    sheet.append(["P1 D1", 25, 24.9691, 0.1])
    sheet.append(["P1 D2", 40, "39,9714", 0.1])
    path = tmp_path / "shop.xlsx"
    book.save(path)
    # The title block above the header is skipped: the header is the row naming the columns.
    table = parsers.read_report(path, columns="tolerance=Tol").table
    assert list(table["deviation"].round(6)) == [-0.0309, -0.0286]
    assert list(table["upper"]) == [0.1, 0.1] and list(table["lower"]) == [-0.1, -0.1]
    assert table["source"].iloc[1].endswith("shop.xlsx#CMM!5")


def test_bad_excel_cell_names_the_row(tmp_path: Path, excel_engine: str) -> None:
    book = openpyxl.Workbook()
    book.active.append(["Name", "Nom", "Meas"])
    book.active.append(["A", 1, "ok?"])
    path = tmp_path / "bad.xlsx"
    book.save(path)
    with pytest.raises(ParseError, match=r"bad.xlsx: <Sheet!2>: column 'actual': expected a number"):
        parsers.read_report(path).table


def test_corrupt_workbook_is_a_parse_error(tmp_path: Path, excel_engine: str) -> None:
    path = tmp_path / "broken.xlsx"
    path.write_bytes(b"PK\x03\x04" + b"\x00" * 200)
    with pytest.raises(ParseError, match=r"broken.xlsx"):
        parsers.read_report(path, format="table").table


def test_deviation_only_and_inch_unit(tmp_path: Path) -> None:
    path = tmp_path / "dev.csv"
    path.write_text("Feature,Nominal,Deviation,Unit\nA,1.0,0.001,inch\nB,10,-0.01,\n", encoding="utf-8")
    table = read_table(path, unit="mm")
    assert table["actual"].tolist() == pytest.approx([25.4254, 9.99])
    assert table["deviation"].tolist() == pytest.approx([0.0254, -0.01])
    assert math.isnan(table["lower"].iloc[0])


def test_contradicting_deviation_and_bad_number_name_the_line(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text("Name,Nominal,Actual,Deviation\nA,1,1.1,0.1\n\nB,1,1.1,0.5\n", encoding="utf-8")
    with pytest.raises(ParseError, match=r"c\.csv:4: stated deviation contradicts"):
        read_table(path)
    path.write_text("Name,Nominal,Actual\nA,1,1.1\nB,1,x1\n", encoding="utf-8")
    with pytest.raises(ParseError, match=r"c\.csv:3: column 'actual': expected a number, found 'x1'"):
        read_table(path)


def test_unknown_unit_and_missing_mapped_header(tmp_path: Path) -> None:
    path = tmp_path / "u.csv"
    path.write_text("Name,Nominal,Actual,Unit\nA,1,1.1,furlong\n", encoding="utf-8")
    with pytest.raises(ParseError, match=r"u\.csv:2: unknown unit 'furlong'"):
        read_table(path)
    with pytest.raises(ParseError, match=r"mapped header.*'Meas'"):
        read_table(path, columns="actual=Meas")


def test_columns_option_selects_the_table_reader_for_a_canonical_looking_file(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text("characteristic,nominal,actual,Soll2\nA,1,1.1,5\n", encoding="utf-8")
    assert parsers.read_report(path, columns="nominal=Soll2").table["nominal"].iloc[0] == 5.0


def test_title_block_above_a_csv_header_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "export.csv"
    path.write_text(
        "Inspection report, cycle 7\nOperator: J. Smith\n\nFeature;Nominal;Actual\nA;10;10,02\n", encoding="utf-8"
    )
    table = read_table(path)
    assert table["deviation"].tolist() == pytest.approx([0.02])
    assert table["source"].iloc[0].endswith("export.csv:5")
