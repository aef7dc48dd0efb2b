"""The geometry and uncertainty columns beside QIF's (issues 39, 40): DMIS feature positions read
against the file's own ``F``/``FA`` statements (joined here, not by the reader), CALYPSO feature names
and datums, a shop table's actual positions and uncertainty, and the uncertainty a matched part keeps."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import SAMPLES, SHARED

import parsers
from setupfix.core.errors import ParseError
from setupfix.model import load_model
from setupfix.model.measurements import match_parts

DMIS_FILES = sorted([*(SHARED / "cmm-samples" / "dmis_dmo").glob("*.dmo"), *SAMPLES.glob("*/*.dmo")])


def _statements(path: Path) -> dict[str, list[str]]:
    """``F(label)`` / ``FA(label)`` → the words after ``CART``: continuation lines (a line ending in
    ``$`` or ``$$``) joined, ``$$`` comment lines dropped."""
    lines = path.read_bytes().decode("utf-8", errors="replace").replace("\r", "").split("\n")
    joined: list[str] = []
    carry = ""
    for line in lines:
        if not carry and line.lstrip().startswith("$$"):
            continue
        text = carry + (line.lstrip() if carry else line)
        if text.rstrip().endswith("$"):
            carry = text.rstrip().rstrip("$")
            continue
        carry = ""
        joined.append(text.strip())
    out: dict[str, list[str]] = {}
    for statement in joined:
        match = re.match(r"^(FA?)\((.+?)\)=FEAT/(.*)$", statement)
        if match:
            words = [w.strip() for w in match.group(3).split(",")]
            upper = [w.upper() for w in words]
            out[f"{match.group(1)}({match.group(2)})"] = words[upper.index("CART") + 1 :] if "CART" in upper else []
    return out


def _point(words: list[str]) -> tuple[float, float, float] | None:
    try:
        return (float(words[0]), float(words[1]), float(words[2]))
    except (IndexError, ValueError):
        return None


@pytest.mark.parametrize("path", DMIS_FILES, ids=[p.name for p in DMIS_FILES])
def test_every_dmis_position_is_the_files(path: Path) -> None:
    """Property over every real and bundled DMIS output: each row's nominal and actual position and
    feature name are its feature's ``F`` and ``FA`` statements (lengths in mm: the samples are in mm)."""
    text = path.read_text(encoding="utf-8", errors="replace").upper()
    assert "UNITS/MM" in text
    table = parsers.read_report(path).table
    features = _statements(path)
    checked = 0
    for row in table.to_dict("records"):
        label = str(row["feature_id"])
        nominal = _point(features.get(f"F({label})", []))
        actual = _point(features.get(f"FA({label})", []))
        assert nominal is not None or actual is not None, row["source"]
        for cols, expected in ((("x", "y", "z"), nominal), (("x_actual", "y_actual", "z_actual"), actual)):
            got = tuple(float(row[c]) for c in cols)
            if expected is None:
                assert all(math.isnan(v) for v in got), row["source"]
            else:
                assert got == pytest.approx(expected, rel=1e-12, abs=1e-12), row["source"]
        checked += 1
    assert checked == len(table) > 0


def test_a_dmis_feature_direction_is_its_stated_unit_vector(tmp_path: Path) -> None:
    path = tmp_path / "d.dmo"
    path.write_text(
        "\n".join(
            [
                "DMISMN/'t',04.0",
                "UNITS/INCH,ANGDEC",
                "F(H1)=FEAT/CYLNDR,INNER,CART,1,2,3,0,0,-1,0.5",
                "T(H1_X)=TOL/CORTOL,XAXIS,-0.01,0.01",
                "T(H1_P)=TOL/POS,3D,0.02,DAT(A),DAT(B)",
                "F(C2)=FEAT/CIRCLE,INNER,CART,4,5,6,,,,0.5",
                "T(C2_Y)=TOL/CORTOL,YAXIS,-0.01,0.01",
                "FA(H1)=FEAT/CYLNDR,CART,1.001,2.002,3,0,0,-1,0.5",
                "TA(H1_X)=TOL/CORTOL,XAXIS,0.001,INTOL",
                "TA(H1_P)=TOL/POS,3D,0.0045,INTOL",
                "FA(C2)=FEAT/CIRCLE,CART,4,5.001,6,,,,0.5",
                "TA(C2_Y)=TOL/CORTOL,YAXIS,0.001,INTOL",
                "ENDFIL",
            ]
        )
        + "\n",
        encoding="utf-8",
    )
    table = parsers.read_report(path).table.set_index("characteristic")
    assert tuple(table.loc["H1_X", ["feature_nx", "feature_ny", "feature_nz"]]) == (0.0, 0.0, -1.0)
    assert tuple(table.loc["H1_X", ["x_actual", "y_actual", "z_actual"]]) == pytest.approx((25.4254, 50.8508, 76.2))
    assert table.loc["H1_P", "datums"] == "A|B" and table.loc["H1_X", "datums"] == ""
    assert table.loc["C2_Y", ["feature_nx", "feature_ny", "feature_nz"]].isna().all()  # i,j,k left empty
    assert (table["feature_id"] == ["H1", "H1", "C2"]).all()


CALYPSO = SHARED / "cmm-samples" / "calypso" / "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt"


@pytest.mark.skipif(not CALYPSO.is_file(), reason="the CALYPSO sample lives in ../shared")
def test_calypso_rows_keep_their_feature_name() -> None:
    table = parsers.read_report(CALYPSO).table
    first = table.iloc[0]
    assert (first["characteristic"], first["feature_id"]) == ("D Zyl. Mitte 9", "Zylinder Mitte")
    assert (table["datums"] == "").all()  # the sample's datumA/B/Cid columns are empty


def test_a_shop_table_maps_actual_positions_and_uncertainty(tmp_path: Path) -> None:
    path = tmp_path / "shop.csv"
    path.write_text(
        "Name,Nom,Meas,Lower,Upper,X,Y,Z,X actual,Y actual,Z actual,Uncertainty,Unit\n"
        "A,10,10.01,-0.1,0.1,1,2,3,1.001,2,3,0.002,inch\n"
        "B,5,5.001,-0.1,0.1,1,2,3,,,,,mm\n",
        encoding="utf-8",
    )
    table = parsers.read_report(path, format="table").table
    assert tuple(table.loc[0, ["x_actual", "y_actual", "z_actual", "uncertainty"]]) == pytest.approx(
        (1.001 * 25.4, 2 * 25.4, 3 * 25.4, 0.002 * 25.4)
    )
    assert table.loc[1, ["x_actual", "uncertainty"]].isna().all()
    path.write_text("Name,Nom,Meas,Uncertainty\nA,10,10.01,-0.002\n", encoding="utf-8")
    with pytest.raises(ParseError, match=r"shop\.csv:2.*negative uncertainty"):
        parsers.read_report(path, format="table")


def test_a_matched_part_keeps_each_dimensions_uncertainty_in_the_model_unit(tmp_path: Path) -> None:
    """U reaches the part in the model's unit, per dimension, NaN where the report has none."""
    model = load_model(SAMPLES / "guide_pins" / "model.toml")
    table = parsers.read_report(SAMPLES / "guide_pins" / "cycle_01.csv").table.copy()
    table["uncertainty"] = np.nan
    table.loc[0, "uncertainty"] = 0.004
    table.loc[0, "unit"] = "inch"  # the row's unit: its U is 0.004 inch
    part = match_parts(model, table)[0]
    assert part.uncertainty is not None and part.uncertainty.shape == (len(model.dimensions),)
    names = [d.name for d in model.dimensions]
    i = names.index(str(table.loc[0, "characteristic"]))
    factor = 25.4 if model.unit == "mm" else 1.0
    assert part.uncertainty[i] == pytest.approx(0.004 * factor)
    assert np.isnan(np.delete(part.uncertainty, i)).all()


@pytest.mark.parametrize("name", ["bracket_two_parts.txt", "bracket_ncgage.csv"])
def test_pcdmis_rows_carry_their_features_location_from_its_axis_rows(name: str) -> None:
    """A PC-DMIS location block's X/Y/Z rows are the feature's nominal and measured coordinates; every
    row of the block (its diameter too) carries them, NaN for an axis it does not state."""
    table = parsers.read_report(SAMPLES / "pcdmis" / name).table
    dim = table["characteristic"].str.rsplit(".", n=1).str[0]  # the DIM block (the export: the feature)
    for _, block in table.groupby([table["part"], dim], sort=False):
        for col, measured, letter in (("x", "x_actual", "X"), ("y", "y_actual", "Y"), ("z", "z_actual", "Z")):
            rows = block[block["characteristic"].str.endswith(f".{letter}")]
            if rows.empty:
                continue
            assert (block[col] == rows["nominal"].iloc[-1]).all() and (block[measured] == rows["actual"].iloc[-1]).all()
    first = table.iloc[0]
    assert (first["feature_id"], first["x"], first["y"]) == ("CIR1", 50.0, 30.0)
    assert math.isnan(first["z"])
    if name.endswith(".txt"):
        distance = table[table["characteristic"] == "DIST1.M"].iloc[0]
        assert (distance["feature_id"], distance["between"]) == ("", "CIR1;CIR2")
