"""The optional ``axis`` column: what the QIF and DMIS readers take from the report's vectors.

Each expected axis below was checked by hand against the element or statement quoted
beside it in the sample file.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES, shared_path
from hypothesis import given
from hypothesis import strategies as st

import parsers
from parsers.axes import AXIS_ANGLE_DEG, axis_word, vector_axis
from setupfix.core.errors import SetupfixError
from setupfix.usecases.model_init import name_axis
from setupfix.usecases.parse import OUTPUT_COLUMNS


def test_vector_axis_either_sense_and_oblique_gives_none() -> None:
    assert vector_axis((0, 0, -1)) == "Z" and vector_axis((2, 0, 0)) == "X" and vector_axis((0, -0.5, 0)) == "Y"
    assert vector_axis((1, 1, 0)) == "" and vector_axis((0, 0, 0)) == "" and vector_axis((math.nan, 0, 1)) == ""
    assert vector_axis(None) == "" and vector_axis((1, 0)) == ""
    # the QIF widget's tilted face: 10° from Y, oblique
    assert vector_axis((0, 0.98480775301219, 0.173648177667034)) == ""
    assert axis_word("zaxis") == "Z" and axis_word("DIAMETER") == "" and axis_word("RADIAL") == ""


@given(angle=st.floats(0, 45), turn=st.floats(0, 2 * math.pi), which=st.integers(0, 2), sign=st.sampled_from([1, -1]))
def test_vector_axis_is_the_axis_within_five_degrees(angle: float, turn: float, which: int, sign: int) -> None:
    if abs(angle - AXIS_ANGLE_DEG) < 1e-9:
        return  # the boundary itself is decided by rounding
    a = math.radians(angle)
    v = np.roll([sign * math.cos(a), math.sin(a) * math.cos(turn), math.sin(a) * math.sin(turn)], which)
    assert vector_axis(tuple(v)) == ("XYZ"[which] if angle < AXIS_ANGLE_DEG else "")


def _axes(path: Path) -> dict[str, str]:
    table = parsers.read_report(path).table
    assert set(table["axis"]) <= {"", "X", "Y", "Z"}
    return dict(zip(table["characteristic"], table["axis"], strict=True))


def test_qif_axes_from_directions_vectors_and_normals() -> None:
    # <Direction>XAXIS</Direction> … of LinearCoordinateCharacteristicNominal; DIST1 joins two circles
    # whose normals are oblique (0.042 -0.909 -0.414): no axis
    axes = _axes(SAMPLES / "qif" / "QIF3_Results_Sample.QIF")
    assert (axes["1"], axes["2"], axes["3"], axes["DIST1"]) == ("X", "Y", "Z", "")
    axes = _axes(SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF")
    # DS002 <AnalysisVector>1 0 0</AnalysisVector>, DS003 0 1 0; DISTANCEBETWEEN4 THREEDIMENSIONAL, no vector
    assert (axes["DS002"], axes["DS003"], axes["DISTANCEBETWEEN4"]) == ("X", "Y", "")
    # slot: OppositeParallelLines, CenterLine Vector 0 1 0, Normal 0 0 1: length along Y, width across (X)
    assert (axes["LENGTH1"], axes["WIDTH1"]) == ("Y", "X")
    # diameters and the radius are sizes: no axis, although their cylinders' axes are along Z
    assert {axes[n] for n in axes if n.startswith(("DIAMETER", "RADIUS"))} == {""}
    axes = _axes(SAMPLES / "qif" / "QIF3_WIDGET_QIF_RESULTS.QIF")
    # '12': planes with normals 0 1 0 and 0 -1 0; '19': point (0 0 -1) to plane (0 0 1); '13': plane 0 -1 0
    assert (axes["12"], axes["19"], axes["13"]) == ("Y", "Z", "Y")
    # point profiles along the point normal: '109' 0 0 -1, '110' 0 -1 0; '1' on a plane 10° from Y: oblique
    assert (axes["109"], axes["110"], axes["1"]) == ("Z", "Y", "")
    # '15': a width whose centre line (0.0026 -0.9998 -0.019) runs along its own normal (0 1 0): no direction
    assert axes["15"] == ""
    # sheet metal: the point normals are oblique; edge points' deviations are along an unstated normal
    assert set(_axes(SAMPLES / "qif" / "QIF3_SheetMetal_Results_6_samples.QIF").values()) == {""}
    # the FAIR files give no feature geometry and no vectors at all
    assert set(_axes(SAMPLES / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif").values()) == {""}


@pytest.mark.needs_shared
def test_qif_axes_on_shared_samples() -> None:
    axes = _axes(shared_path("cmm-samples", "qif", "NIST_MTC_Incoming_CoverResults_20_samples.QIF"))
    assert (axes["DISTANCEBETWEEN6"], axes["DISTANCEBETWEEN1"], axes["DISTANCEBETWEEN2"]) == ("Z", "X", "Y")
    axes = _axes(shared_path("cmm-samples", "qif", "QIF3_PTS_SAMPLE.QIF"))
    # DISTANCE1_Y: AnalysisVector 0 1 0; PROF1: point normal -0.643 0 0.766 (40° from Z)
    assert (axes["X_CIRCLE1"], axes["Z_CIRCLE2"], axes["DISTANCE1_Y"], axes["PROF1"]) == ("X", "Z", "Y", "")


@pytest.mark.needs_shared
def test_dmis_axes_from_cortol_and_point_normals() -> None:
    axes = _axes(shared_path("cmm-samples", "dmis_dmo", "DMO_Example1_PiezaDemo.dmo"))
    # TA(Cono_9_X)=TOL/CORTOL,XAXIS,…; TA(Esfera_10_DIAM)=TOL/CORTOL,DIAMETER,…
    assert (axes["Cono_9_X"], axes["Cono_9_Y"], axes["Cono_9_Z"], axes["Esfera_10_DIAM"]) == ("X", "Y", "Z", "")
    axes = _axes(shared_path("cmm-samples", "dmis_dmo", "DMO_Impeller_6_Blades_Part_1.dmo"))
    # F(SP_1)=FEAT/POINT,CART,0,0,44.3367,0,0,1: its profile (TA SP_1_DN) is along Z;
    # F(SP_00)=…,-0.3438,-0.7266,0.5946: oblique
    assert (axes["SP_1_DN"], axes["SP_00_DN"], axes["SP_00_X"]) == ("Z", "", "X")


@pytest.mark.slow
@pytest.mark.needs_shared
def test_every_qif_and_dmis_sample_states_axes_its_names_agree_with() -> None:
    """Property over the real samples: every stated axis is X/Y/Z, every CORTOL row's axis is its name's
    suffix, and where a name states an axis the report never states another."""
    checked = 0
    for folder, pattern in (("qif", "*"), ("dmis_dmo", "*.dmo")):
        for path in sorted(shared_path("cmm-samples", folder).glob(pattern)):
            if path.suffix.lower() not in (".qif", ".dmo"):
                continue
            try:
                table = parsers.read_report(path).table
            except SetupfixError:  # plans and the samples refused on purpose (test_golden.REFUSED)
                continue
            stated = table.loc[table["axis"] != "", ["characteristic", "axis"]]
            named = stated["characteristic"].map(name_axis)
            assert ((named == stated["axis"]) | named.isna()).all(), path.name
            if folder == "dmis_dmo":  # every _X/_Y/_Z result of these files is a CORTOL of that axis
                suffixed = table["characteristic"].map(name_axis).notna()
                assert (table.loc[suffixed, "axis"] == table.loc[suffixed, "characteristic"].str[-1]).all()
            checked += len(stated)
    assert checked >= 3 * 3 * 158


def test_formats_without_directions_have_no_axis_column() -> None:
    table = parsers.read_report(SAMPLES / "guide_pins" / "cycle_01.csv").table
    assert "axis" not in table


def test_axis_round_trips_through_parse_and_the_canonical_reader(tmp_path: Path) -> None:
    from setupfix.cli import main

    out = tmp_path / "all.csv"
    report = SAMPLES / "qif" / "QIF3_WIDGET_QIF_RESULTS.QIF"
    assert main(["parse", str(report), str(SAMPLES / "guide_pins" / "cycle_01.csv"), "--out", str(out)]) == 0
    back = parsers.read_report(out).table
    direct = parsers.read_report(report).table
    # ``axis`` follows the canonical columns and ``reference``; the geometry columns come after it
    assert "axis" in back.columns and len(back) == len(direct) + 28
    assert back["axis"].iloc[: len(direct)].tolist() == direct["axis"].tolist()
    assert set(back["axis"].iloc[len(direct) :]) == {""}  # the CSV states none
    written = pd.read_csv(out, dtype=str, keep_default_na=False)
    assert list(written.columns).index("axis") == len(OUTPUT_COLUMNS)
