"""``model init`` writes the axes, directions, weights and sizes the reports state (issue 23).

The property test reads every sample that states geometry (a measuring direction or a
size: QIF, DMIS, CALYPSO, PC-DMIS) and checks each dimension of its scaffold against the
report's own row, computed here from the canonical table's columns, not from the
scaffold's code.  Multi-axis scaffolds are checked as TOML, then loaded and corrected.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES, SHARED

import parsers
from parsers.geometry import INTERPOLATED
from setupfix.core.errors import ModelError, SetupfixError, SourceLocation
from setupfix.model import load_model, model_from_dict
from setupfix.usecases.correct import correct_report
from setupfix.usecases.model_init import scaffold_from_tables, scaffold_model
from setupfix.usecases.model_map import parse_answer
from setupfix.usecases.requests import CorrectRequest

AXES = ("X", "Y", "Z")
#: Every feature made on G54 by tool 1: the answer to a multi-axis scaffold's questions (issue 39) that gives
#: the one-setup, one-tool topology these tests check.
ONE_SETUP = parse_answer("*=G54,T1", SourceLocation("test"))
DMIS = SHARED / "cmm-samples" / "dmis_dmo"


def _table(path: Path) -> pd.DataFrame | None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return parsers.read_report(path).table
    except SetupfixError:
        return None


def _states_geometry(table: pd.DataFrame) -> bool:
    return "nx" in table and bool(table["nx"].notna().any() or (table["size"].fillna("") != "").any())


def _report_geometry(table: pd.DataFrame) -> dict[str, tuple[Any, ...]]:
    """name → (unit direction, size, feature, side) of its rows, for names whose rows all agree."""
    out: dict[str, tuple[Any, ...]] = {}
    conflicting = set()
    for row in table.itertuples(index=False):
        n = np.array([row.nx, row.ny, row.nz], dtype=float)
        direction = tuple(n / np.linalg.norm(n)) if np.isfinite(n).all() and np.linalg.norm(n) > 0 else None
        geometry = (direction, row.size or "", row.feature or "", row.side or "")
        name = str(row.characteristic).strip()
        if name in out and out[name] != geometry:
            conflicting.add(name)
        out.setdefault(name, geometry)
    return {k: v for k, v in out.items() if k not in conflicting}


def check_scaffold(raw: dict[str, Any], table: pd.DataFrame) -> int:
    """Assert every dimension's relations are the ones its report row states; the number checked."""
    geometry = _report_geometry(table)
    process = raw["process"]
    multi = "axes" in process
    assert process["draft"] is True
    measured: set[str] = set()
    radius = False
    checked = 0
    for dim in raw["dimensions"].values():
        if dim["name"] not in geometry or dim.get("kind") == "position" or len(dim["features"]) != 1:
            continue  # a zone, or a distance: test_model_init_geometry.py checks those
        (fid,) = dim["features"]
        feature = raw["features"][fid]
        direction, size, kind, side = geometry[dim["name"]]
        checked += 1
        if size:
            assert not feature.get("wks") and not feature.get("tools"), dim  # no translation moves a size
            if multi:
                assert dim["kind"] == "size" and "axis" not in dim and "direction" not in dim
            if multi and kind in INTERPOLATED:
                sign = 1 if side == "outer" else -1
                assert feature["radius"] == {"T1": sign * (1 if size == "radius" else 2)}, dim
                radius = True
            else:
                assert "radius" not in feature, dim
        elif direction is not None and multi:
            assert feature["wks"] == {"W1": 1}
            if abs(direction[2]) > 1e-9:  # tool length: where a dimension sees the spindle Z
                assert feature["tools"] == {"T1": 1}, dim
            if "axis" in dim:
                assert direction == tuple(1.0 if a == dim["axis"] else 0.0 for a in AXES), dim
            else:
                assert dim["direction"] == pytest.approx(direction, abs=1e-9), dim
            measured |= {a for a, v in zip(AXES, direction, strict=True) if abs(v) > 1e-9}
        elif direction is not None:
            k = AXES.index(process["axis"])
            if abs(direction[k]) <= 1e-9:
                assert feature["wks"] == {}, dim
            else:
                assert feature["wks"]["W1"] == pytest.approx(direction[k], abs=1e-9), dim
                tools = {"T1": feature["wks"]["W1"]} if process["axis"] == "Z" else {}
                assert feature["tools"] == tools, dim
    if multi:
        zones = {a for d in raw["dimensions"].values() if d.get("kind") == "position" for a in d["axes"]}
        assert (
            measured
            <= set(process["axes"])
            <= measured | zones | {"Z"} | set(d.get("axis") for d in raw["dimensions"].values())
        )
        assert ("radius" in raw.get("tools", {}).get("T1", {})) == radius
    return checked


def _samples() -> list[Path]:
    roots = [SAMPLES] + ([SHARED / "cmm-samples"] if (SHARED / "cmm-samples").is_dir() else [])
    return sorted(
        p
        for root in roots
        for p in root.glob("*/*")
        if p.suffix.lower() in (".qif", ".dmo", ".txt", ".csv") and "SOURCES" not in p.name
    )


@pytest.mark.slow
def test_every_sample_with_vectors_gets_the_axes_and_weights_it_states() -> None:
    done: dict[str, int] = {}
    for path in _samples():  # a sample in both folders is checked twice, under one name
        table = _table(path)
        if table is None or not _states_geometry(table):
            continue
        try:
            scaffold = scaffold_from_tables([(str(path), table)], answers=ONE_SETUP)
        except ModelError:
            continue  # no toleranced length characteristic
        raw = tomllib.loads(scaffold.text)
        done[path.name] = check_scaffold(raw, table)
        if not scaffold.axes:  # a one-axis scaffold loads today
            model_from_dict(raw)
    # the formats that state geometry: QIF, DMIS, PC-DMIS always; CALYPSO where ../shared is present
    assert {
        "cycle_01.dmo",
        "QIF3_WIDGET_QIF_RESULTS.QIF",
        "bracket_two_parts.txt",
        "bracket_ncgage.csv",
        "NIST_MTC_Incoming_PlateResults_20_samples.QIF",
    } <= done.keys()
    assert sum(done.values()) > 150
    if (SHARED / "cmm-samples").is_dir():
        assert {
            "DMO_Impeller_6_Blades_Part_1.dmo",
            "DMO_Example1_PiezaDemo.dmo",
            "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt",
        } <= done.keys()
        assert sum(done.values()) > 2500


@pytest.mark.needs_shared
def test_an_oblique_dmis_normal_gives_its_components_not_one() -> None:
    path = DMIS / "DMO_Impeller_6_Blades_Part_1.dmo"
    if not path.exists():
        pytest.skip(f"{path} absent")
    # F(SP_00)=FEAT/POINT,CART,22.7205,-13.4298,40.9154,-0.3438,-0.7266,0.5946: TA(SP_00_DN) along that normal
    n = np.array([-0.3438, -0.7266, 0.5946])
    n /= np.linalg.norm(n)
    multi = tomllib.loads(scaffold_model([path]).text)
    (dn,) = [d for d in multi["dimensions"].values() if d["name"] == "SP_00_DN"]
    assert dn["direction"] == pytest.approx(n, abs=1e-12) and "axis" not in dn
    assert multi["features"][next(iter(dn["features"]))]["position"] == [22.7205, -13.4298, 40.9154]
    one = tomllib.loads(scaffold_model([path], axis="Z").text)
    (dn,) = [d for d in one["dimensions"].values() if d["name"] == "SP_00_DN"]
    feature = one["features"][next(iter(dn["features"]))]
    assert feature["wks"] == {"W1": pytest.approx(n[2], abs=1e-12)} and feature["tools"] == {"T1": pytest.approx(n[2])}
    assert 0.59 < n[2] < 0.6  # not +1


def test_a_normal_facing_minus_z_gives_minus_one_in_a_one_axis_scaffold(tmp_path: Path) -> None:
    path = tmp_path / "down.dmo"
    path.write_text(
        "DMISMN/'down',04.0\nUNITS/MM,ANGDEC\n"
        "F(TOP)=FEAT/POINT,CART,0,0,10,0,0,1\nT(TOP_DN)=TOL/PROFP,-0.05,0.05\n"
        "F(BOT)=FEAT/POINT,CART,0,0,0,0,0,-1\nT(BOT_DN)=TOL/PROFP,-0.05,0.05\n"
        "FA(TOP)=FEAT/POINT,CART,0,0,10.01,0,0,1\nTA(TOP_DN)=TOL/PROFP,0.01,INTOL\n"
        "FA(BOT)=FEAT/POINT,CART,0,0,0.02,0,0,-1\nTA(BOT_DN)=TOL/PROFP,-0.02,INTOL\nENDFIL\n",
        encoding="utf-8",
    )
    scaffold = scaffold_model([path], axis="Z")  # the DMIS labels name its features: one axis on request
    raw = tomllib.loads(scaffold.text)
    assert not scaffold.axes and raw["process"]["axis"] == "Z"
    weights = {d["name"]: raw["features"][next(iter(d["features"]))]["wks"] for d in raw["dimensions"].values()}
    assert weights == {"TOP_DN": {"W1": 1}, "BOT_DN": {"W1": -1}}
    (cycle,) = correct_report(CorrectRequest(model_from_dict(raw, str(path))), path).cycles
    assert cycle.verdict == "hold" and [r.rule for r in cycle.recommendation.rules] == ["draft"]


@pytest.mark.needs_shared
def test_sizes_move_only_by_a_radius_and_only_where_interpolated() -> None:
    path = DMIS / "DMO_Example1_PiezaDemo.dmo"
    if not path.exists():
        pytest.skip(f"{path} absent")
    raw = tomllib.loads(scaffold_model([path], answers=ONE_SETUP).text)
    by_name = {
        d["name"]: (d, raw["features"][next(iter(d["features"]))]) for d in raw["dimensions"].values() if d["features"]
    }
    circle, circle_feature = by_name["Círculo_13_DIAM"]  # F(Círculo_13)=FEAT/CIRCLE,INNER,…: a milled bore
    assert circle["kind"] == "size" and set(circle_feature) == {"radius", "position"}
    assert circle_feature["radius"] == {"T1": -2}
    sphere, sphere_feature = by_name["Esfera_10_DIAM"]  # a sphere's diameter: no offset register moves it
    assert sphere["kind"] == "size" and sphere_feature["wks"] == {} and "radius" not in sphere_feature
    assert raw["tools"]["T1"] == {"register": "H1", "radius": "D1"}
    for name, (dim, feature) in by_name.items():
        if dim.get("kind") != "size":
            assert "radius" not in feature, name


def test_a_drilled_hole_and_a_boss_without_feature_type_or_with_one() -> None:
    table = pd.DataFrame(
        {
            "characteristic": ["Hole 1 D", "Boss D", "Bore D", "Step Z"],
            "nominal": [6.0, 20.0, 12.0, 5.0],
            "actual": [6.01, 20.0, 12.0, 5.0],
            "lower": [-0.05] * 4,
            "upper": [0.05] * 4,
            "nx": [np.nan, np.nan, np.nan, 0.0],
            "ny": [np.nan, np.nan, np.nan, 0.0],
            "nz": [np.nan, np.nan, np.nan, 1.0],
            "size": ["diameter", "diameter", "diameter", ""],
            "feature": ["", "cylinder", "circle", "plane"],
            "side": ["", "outer", "inner", ""],
        }
    )
    scaffold = scaffold_from_tables([("r.csv", table)], answers=ONE_SETUP)
    raw = tomllib.loads(scaffold.text)
    features = {d["name"]: raw["features"][next(iter(d["features"]))] for d in raw["dimensions"].values()}
    assert features == {
        "Hole 1 D": {"wks": {}},
        "Boss D": {"radius": {"T1": 2}},
        "Bore D": {"radius": {"T1": -2}},
        "Step Z": {"wks": {"W1": 1}, "tools": {"T1": 1}},
    }
    assert "no stated type (drilled or reamed?)" in scaffold.text and scaffold.sizes == 3
    # a multi-axis scaffold only to hold the radius register: axes = the spindle
    assert scaffold.axes == ("Z",)


def test_a_report_measuring_y_gets_no_tool_length_register() -> None:
    table = pd.DataFrame(
        {
            "characteristic": ["Distanz Y 5mm", "Distanz Y 33mm"],
            "nominal": [5.0, 33.0],
            "actual": [5.01, 33.0],
            "lower": [-0.1, -0.1],
            "upper": [0.1, 0.1],
        }
    )
    scaffold = scaffold_from_tables([("calypso.txt", table)])
    raw = tomllib.loads(scaffold.text)
    assert raw["process"]["axis"] == "Y" and "tools" not in raw and not scaffold.axes
    # distances (issue 39): a work offset moves both ends alike, so none moves them
    assert all(f == {"wks": {}, "tools": {}} for f in raw["features"].values())
    assert "a tool length offset acts along the spindle" in scaffold.text
    model = model_from_dict(raw)
    assert [r.id for r in model.registers] == ["W1"]


@pytest.mark.needs_shared
def test_the_calypso_sample_is_multi_axis_and_its_y_distances_have_no_tool_length() -> None:
    path = SHARED / "cmm-samples" / "calypso" / "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt"
    if not path.exists():
        pytest.skip(f"{path} absent")
    scaffold = scaffold_model([path], answers=ONE_SETUP)
    raw = tomllib.loads(scaffold.text)
    assert scaffold.axes == ("X", "Y", "Z")
    for dim in raw["dimensions"].values():
        if not dim["features"]:
            continue  # a distance naming no ends: nothing moves it (issue 39)
        feature = raw["features"][next(iter(dim["features"]))]
        if dim.get("axis") in ("X", "Y"):
            assert feature == {"wks": {"W1": 1}, "position": feature["position"]}, dim
        if dim.get("axis") == "Z":
            assert feature["tools"] == {"T1": 1}
    # its two diameters state no feature type (idsymbol diameter only): uncorrectable, no radius register
    # and its Z dimensions are distances naming no ends: no tool length register either (issue 39)
    assert sum(d.get("kind") == "size" for d in raw["dimensions"].values()) == 2 and "tools" not in raw


def test_a_multi_axis_scaffold_loads_and_holds_as_a_draft_and_solves_without_the_key(tmp_path: Path) -> None:
    report = SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF"
    out = tmp_path / "plate.toml"
    out.write_text(scaffold_model([report], answers=ONE_SETUP).text, encoding="utf-8")
    model = load_model(out)
    assert model.multi_axis and model.draft and model.axes == ("X", "Y", "Z")
    assert {"W1.X", "W1.Y", "W1.Z", "T1", "T1.R"} <= set(model.register_ids)
    outcome = correct_report(CorrectRequest(model), report)
    assert {c.verdict for c in outcome.cycles} == {"hold"}
    assert all(not any(c.recommendation.x) for c in outcome.cycles)
    solved = correct_report(CorrectRequest(dataclasses.replace(model, draft=False)), report)
    assert all(c.result.status in ("optimal", "rounded", "time_limit") or c.verdict == "reject" for c in solved.cycles)
    assert all(math.isfinite(c.result.margin_after) for c in solved.cycles)
