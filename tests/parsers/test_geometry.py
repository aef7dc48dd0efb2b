"""The geometry columns (``nx, ny, nz, feature, size, side``) as each report states them, read from real samples."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES, SHARED

import parsers
from parsers.geometry import GEOMETRY_COLUMNS, axis_vector, geometry_cells, unit_vector


def read(path: Path) -> pd.DataFrame:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return parsers.read_report(path).table


def row(table: pd.DataFrame, name: str) -> pd.Series:
    return table[table["characteristic"] == name].iloc[0]


def test_helpers() -> None:
    assert unit_vector([0.0, 3.0, 4.0]) == (0.0, 0.6, 0.8)
    assert unit_vector([0.0, 0.0, 0.0]) is None and unit_vector([math.nan, 0, 1]) is None and unit_vector(None) is None
    assert axis_vector("Y") == (0.0, 1.0, 0.0) and axis_vector("") is None
    cells = geometry_cells()
    assert (
        list(cells) == list(GEOMETRY_COLUMNS)
        and isinstance(cells["nx"], float)
        and math.isnan(cells["nx"])
        and cells["size"] == ""
    )


def test_qif_states_vectors_oblique_ones_too_feature_types_and_sides() -> None:
    table = read(SAMPLES / "qif" / "QIF3_WIDGET_QIF_RESULTS.QIF")
    tilted = row(table, "1")  # the widget's 10°-tilted face: a distance along its normal (0, cos 10°, sin 10°)
    assert (tilted["nx"], tilted["ny"], tilted["nz"]) == pytest.approx(
        (0.0, math.cos(math.radians(10)), math.sin(math.radians(10))), abs=1e-6
    )
    assert tilted["axis"] == "" and tilted["feature"] == "plane"
    down = row(table, "109")  # a point profile on a face whose normal is -Z
    assert (down["nx"], down["ny"], down["nz"], down["axis"]) == (0.0, 0.0, -1.0, "Z")
    bore = row(table, "10")
    assert (bore["feature"], bore["size"], bore["side"]) == ("cylinder", "diameter", "inner")
    assert math.isnan(bore["nx"])  # a size has no measuring direction
    slot = read(SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF")
    width = row(slot, "WIDTH1")
    assert (width["feature"], width["size"], width["side"], width["axis"]) == ("slot", "width", "inner", "X")
    assert abs(width["nx"]) == 1.0


def test_pcdmis_axis_letters_and_the_located_feature() -> None:
    table = read(SAMPLES / "pcdmis" / "bracket_two_parts.txt")
    x, d = row(table, "LOC1.X"), row(table, "LOC1.D")
    assert (x["nx"], x["ny"], x["nz"], x["feature"], x["size"]) == (1.0, 0.0, 0.0, "circle", "")
    assert math.isnan(d["nx"]) and (d["feature"], d["size"]) == ("circle", "diameter")
    csv = read(SAMPLES / "pcdmis" / "bracket_ncgage.csv")  # the column-wise reader states the same
    assert set(GEOMETRY_COLUMNS) <= set(csv.columns)


@pytest.mark.needs_shared
def test_dmis_inner_outer_feature_words_and_normals() -> None:
    path = SHARED / "cmm-samples" / "dmis_dmo" / "DMO_Example1_PiezaDemo.dmo"
    if not path.exists():
        pytest.skip(f"{path} absent")
    table = read(path)
    hole = row(table, "Círculo_13_DIAM")  # F(Círculo_13)=FEAT/CIRCLE,INNER,CART,…
    assert (hole["feature"], hole["size"], hole["side"]) == ("circle", "diameter", "inner")
    ball = row(table, "Esfera_10_DIAM")  # a sphere, OUTER
    assert (ball["feature"], ball["size"], ball["side"]) == ("sphere", "diameter", "outer")
    z = row(table, "Cono_9_Z")
    assert (z["nx"], z["ny"], z["nz"], z["feature"]) == (0.0, 0.0, 1.0, "cone")
    impeller = read(SHARED / "cmm-samples" / "dmis_dmo" / "DMO_Impeller_6_Blades_Part_1.dmo")
    dn = row(impeller, "SP_00_DN")  # F(SP_00)=FEAT/POINT,CART,22.7205,-13.4298,40.9154,-0.3438,-0.7266,0.5946
    n = np.array([-0.3438, -0.7266, 0.5946])
    assert (dn["nx"], dn["ny"], dn["nz"]) == pytest.approx(tuple(n / np.linalg.norm(n)), abs=1e-12)
    assert dn["axis"] == "" and dn["feature"] == "point"


@pytest.mark.needs_shared
def test_calypso_idsymbol_states_sizes() -> None:
    path = SHARED / "cmm-samples" / "calypso" / "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt"
    if not path.exists():
        pytest.skip(f"{path} absent")
    table = read(path)
    assert row(table, "D Zyl. Mitte 9")["size"] == "diameter"  # idsymbol diameter
    distance = row(table, "Distanz X 4mm")  # lengthOfAxis: no direction stated (the name says X)
    assert distance["size"] == "" and math.isnan(distance["nx"]) and row(table, "D Zyl. Mitte 9")["feature"] == ""


def test_calypso_coordinate_symbols_state_their_axis(tmp_path: Path) -> None:
    path = tmp_path / "plan_chr.txt"
    head = "planid\tpartnb\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\tunit\n"
    path.write_text(
        head + "p\t1\tX1\tX-Wert\txValue\t10.01\t10\t0.1\t-0.1\t0.01\tmm\n"
        "p\t1\tR1\tRadius\tradius\t4.99\t5\t0.1\t-0.1\t-0.01\tmm\nEND\n",
        encoding="cp1252",
    )
    table = read(path)
    x, r = row(table, "X1"), row(table, "R1")
    assert (x["nx"], x["ny"], x["nz"], x["size"]) == (1.0, 0.0, 0.0, "")
    assert r["size"] == "radius" and math.isnan(r["nx"])


@pytest.mark.needs_shared
def test_korean_items_and_element_words() -> None:
    path = SHARED / "cmm-samples" / "korean_cmm_txt" / "KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt"
    if not path.exists():
        pytest.skip(f"{path} absent")
    table = read(path)
    bore = row(table, "원1(I).D")  # 원 circle, (I) internal, D its diameter
    assert (bore["feature"], bore["size"], bore["side"]) == ("circle", "diameter", "inner")
    y = row(table, "점2.Y")  # 점 point, Y its coordinate
    assert (y["nx"], y["ny"], y["nz"], y["feature"], y["size"]) == (0.0, 1.0, 0.0, "point", "")
