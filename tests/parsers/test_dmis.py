"""DMIS output reader: continuations, nominal/actual pairing, units, label mismatches, errors."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from conftest import shared_path
from goldens import expect_note

from parsers.dmis import read_dmis, sniff_dmis
from parsers.dmis.statements import parse_statement, split_statements
from setupfix.core.errors import ParseError


def write(tmp_path: Path, lines: list[str], name: str = "p.dmo") -> Path:
    path = tmp_path / name
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("utf-8"))
    return path


HEADER = ["DMISMN/'test',04.0", "UNITS/MM,ANGDEC"]


def test_continuations_join_labels_numbers_and_leading_commas() -> None:
    text = "\n".join(
        [
            "OUTPUT/F(Esfera_10),T(Es$",
            "fera_10_DIAM)",
            ",T(Extra)",
            "FA(C)=FEAT/CONE,CART,$$",
            "   74.9658,92.9064,-0.$",
            "0019",
            "$$ a comment line",
            "ENDFIL",
        ]
    )
    statements = split_statements(text)
    assert statements == [
        (1, "OUTPUT/F(Esfera_10),T(Esfera_10_DIAM),T(Extra)"),
        (4, "FA(C)=FEAT/CONE,CART,74.9658,92.9064,-0.0019"),
        (8, "ENDFIL"),
    ]
    st = parse_statement(*statements[1])
    assert (st.kind, st.label, st.major, st.words[-1]) == ("FA", "C", "FEAT", "-0.0019")


def test_sniffer() -> None:
    assert sniff_dmis("DMISMN/'x',04.0\r\nUNITS/MM")
    assert not sniff_dmis("planid\tpartnb\tid")


def test_cortol_rows_pair_nominal_actual_and_limits(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "F(C1)=FEAT/CIRCLE,INNER,CART,32.5,75.5,-10,,,,15",
            "T(C1_X)=TOL/CORTOL,XAXIS,-0.5,0.5",
            "T(C1_DIAM)=TOL/CORTOL,DIAMETER,-1,1",
            "FA(C1)=FEAT/CIRCLE,INNER,CART,32.4715,75.3768,-9.9257,0,0,1,14.9137",
            "TA(C1_X)=TOL/CORTOL,XAXIS,-0.0285,INTOL",
            " TA(C1_D)=TOL/CORTOL,DIAMETER,-0.0863,INTOL",
            "ENDFIL",
        ],
    )
    table = read_dmis(path)
    x, d = table.iloc[0], table.iloc[1]
    assert (x["characteristic"], x["nominal"], x["actual"], x["lower"], x["upper"]) == (
        "C1_X",
        32.5,
        32.4715,
        -0.5,
        0.5,
    )
    assert x["source"].endswith("p.dmo:7") and x["status"] == "INTOL"
    # TA(C1_D) has no T of its own: the one DIAMETER tolerance of feature C1 applies.
    assert (d["nominal"], d["actual"], d["lower"], d["upper"]) == (15.0, 14.9137, -1.0, 1.0)
    assert (x["x"], x["y"], x["z"]) == (32.5, 75.5, -10.0)


def test_profile_results_are_deviations_from_zero(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "OUTPUT/F(SP),T(SP_PROFP)",
            "F(SP)=FEAT/POINT,CART,1,2,3,0,0,1,0",
            "T(SP_PROFP)=TOL/PROFP,-0.05,0.05",
            "OUTPUT/FA(SP),TA(SP_DN)",
            "FA(SP)=FEAT/POINT,CART,1,2,3.02,0,0,1",
            "TA(SP_DN)=TOL/PROFP,0.0200,INTOL",
        ],
    )
    row = read_dmis(path).iloc[0]
    assert (row["nominal"], row["actual"], row["lower"], row["upper"]) == (0.0, 0.02, -0.05, 0.05)


def test_inch_units_convert_to_mm(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            "UNITS/INCH,ANGDEC",
            "F(P)=FEAT/POINT,CART,1,0,0,0,0,1",
            "T(P_X)=TOL/CORTOL,XAXIS,-0.002,0.002",
            "FA(P)=FEAT/POINT,CART,1.001,0,0,0,0,1",
            "TA(P_X)=TOL/CORTOL,XAXIS,0.001,INTOL",
        ],
    )
    row = read_dmis(path).iloc[0]
    assert row["nominal"] == pytest.approx(25.4) and row["deviation"] == pytest.approx(0.0254)
    assert row["upper"] == pytest.approx(0.0508) and row["unit"] == "mm"


def test_missing_units_statement_warns(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            "F(P)=FEAT/POINT,CART,1,0,0,0,0,1",
            "FA(P)=FEAT/POINT,CART,1.5,0,0,0,0,1",
            "TA(P_X)=TOL/CORTOL,XAXIS,0.5,OUTOL",
        ],
    )
    with expect_note("no UNITS"):
        read_dmis(path)


def test_result_that_is_the_actual_not_the_deviation_is_recognised(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "F(P)=FEAT/POINT,CART,10,0,0,0,0,1",
            "FA(P)=FEAT/POINT,CART,10.2,0,0,0,0,1",
            "TA(P_X)=TOL/CORTOL,XAXIS,10.2,OUTOL",
        ],
    )
    assert read_dmis(path).iloc[0]["deviation"] == pytest.approx(0.2)


def test_contradicting_result_names_the_line(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "F(P)=FEAT/POINT,CART,10,0,0,0,0,1",
            "FA(P)=FEAT/POINT,CART,10.2,0,0,0,0,1",
            "TA(P_X)=TOL/CORTOL,XAXIS,0.7,OUTOL",
        ],
    )
    with pytest.raises(ParseError, match=r"p\.dmo:5: P_X: result 0.7 contradicts FA - F = 0.2"):
        read_dmis(path)


def test_bad_number_names_the_line(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "F(P)=FEAT/POINT,CART,1O,0,0,0,0,1",
            "FA(P)=FEAT/POINT,CART,1,0,0,0,0,1",
            "TA(P_X)=TOL/CORTOL,XAXIS,0.1,INTOL",
        ],
    )
    with pytest.raises(ParseError, match=r"p\.dmo:3: expected a number, found '1O'"):
        read_dmis(path)


def test_program_without_results_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, [*HEADER, "F(P)=FEAT/POINT,CART,1,0,0,0,0,1", "ENDFIL"])
    with pytest.raises(ParseError, match="no tolerance results"):
        read_dmis(path)


def test_real_demo_part_with_split_labels_and_accents() -> None:
    table = read_dmis(shared_path("cmm-samples", "dmis_dmo", "DMO_Example1_PiezaDemo.dmo"))
    sphere = table[table["characteristic"] == "Esfera_10_DIAM"].iloc[0]
    # F: diameter 22; FA: 27.8511; TA: 5.8511 OUTTOL; T: -1/1.
    assert (sphere["nominal"], sphere["actual"], sphere["lower"], sphere["upper"]) == (22.0, 27.8511, -1.0, 1.0)
    assert sphere["status"] == "OUTTOL"
    assert "Círculo_13_DIAM" in set(table["characteristic"])
    assert table["timestamp"].iloc[0] == "2018-03-07T19:49:29"


def test_real_impeller_profile_rows_take_the_feature_profile_tolerance() -> None:
    table = read_dmis(shared_path("cmm-samples", "dmis_dmo", "DMO_Impeller_6_Blades_Part_1.dmo"))
    dn = table[table["characteristic"] == "SP_00_DN"].iloc[0]
    assert (dn["deviation"], dn["lower"], dn["upper"]) == (-0.9258, -0.05, 0.05)
    base = table[table["characteristic"] == "Base_Cylinder_D"].iloc[0]
    assert base["nominal"] == 96.0 and base["actual"] == pytest.approx(95.9717)
    assert table["deviation"].notna().all() and len(table) == 789


def test_position_result_with_modifiers_is_a_zone(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        [
            *HEADER,
            "F(H)=FEAT/CIRCLE,INNER,CART,10,20,0,0,0,1,6",
            "T(H_POS)=TOL/POS,3D,0.1,MMC,DAT(A),DAT(B)",
            "FA(H)=FEAT/CIRCLE,INNER,CART,10.02,20,0,0,0,1,6.01",
            "TA(H_POS)=TOL/POS,3D,0.0618,INTOL,MMC,DAT(A),DAT(B)",
        ],
    )
    row = read_dmis(path).iloc[0]
    assert (row["nominal"], row["actual"], row["upper"], row["status"]) == (0.0, 0.0618, 0.1, "INTOL")
    assert pd.isna(row["lower"])
