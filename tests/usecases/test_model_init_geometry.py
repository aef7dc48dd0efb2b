"""``model init`` knows what each callout measures (issue 39).

A location follows its feature along its axis; a distance between two features is their
difference (no work-offset term survives); a width or diameter is a size only a tool
radius moves; a position callout is a circular zone; which work offset and tool made each
feature is a named question, never a guess.  Checked on the NIST incoming-inspection plate
and cover QIF (real reports) and on small tables whose geometry is written out here.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES, shared_path

import parsers
from setupfix.correction.relation import relation_matrices
from setupfix.model import load_model, model_from_dict
from setupfix.usecases.model_init import scaffold_from_tables, scaffold_model

PLATE = SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF"
FAIR_BOX = ("cmm-samples", "qif", "NIST_MTC_FAIR_Box_Results_19parts.qif")
COVER = ("cmm-samples", "qif", "NIST_MTC_Incoming_CoverResults_20_samples.QIF")


def _raw(path: Path) -> dict[str, Any]:
    return tomllib.loads(scaffold_model([path]).text)


def _dims(raw: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {d["name"]: d for d in raw["dimensions"].values()}


def _table(rows: list[dict[str, Any]]) -> pd.DataFrame:
    frame = pd.DataFrame(rows)
    frame["actual"] = frame["nominal"]
    return frame


def _row(name: str, nominal: float, lower: float, upper: float, **geometry: Any) -> dict[str, Any]:
    return {"characteristic": name, "nominal": nominal, "lower": lower, "upper": upper, **geometry}


def test_the_plate_sizes_are_sizes_and_its_distances_move_with_no_work_offset() -> None:
    raw = _raw(PLATE)
    dims = _dims(raw)
    table = parsers.read_report(PLATE).table
    sizes = set(table.loc[table["size"].fillna("") != "", "characteristic"])
    assert {"WIDTH1", "WIDTH2", "LENGTH1", "DIAMETER8"} <= sizes
    for name in sizes:
        dim = dims[name]
        assert dim["kind"] == "size", name
        (fid,) = dim["features"]
        feature = raw["features"][fid]
        assert "wks" not in feature and "tools" not in feature, name  # only a radius moves a size
    for name in ("DISTANCEBETWEEN4", "DISTANCEBETWEEN5"):
        # the report names neither end: no register moves it as written, and the comment says why
        assert dims[name]["features"] == {}, name
    assert "does not say between which features" in scaffold_model([PLATE]).text
    # no feature of a multi-axis scaffold is moved before its question is answered
    assert all(f.get("wks", {}) == {} and "tools" not in f for f in raw["features"].values())


def test_the_plate_position_callout_is_a_zone_on_its_feature_across_its_axis() -> None:
    raw = _raw(PLATE)
    zone = _dims(raw)["POSITION1"]
    table = parsers.read_report(PLATE).table
    row = table[table["characteristic"] == "POSITION1"].iloc[0]
    assert zone["kind"] == "position" and zone["diameter"] == pytest.approx(float(row["upper"]))
    assert "lower" not in zone and "upper" not in zone and "nominal" not in zone
    (fid,) = zone["features"]
    feature = raw["features"][fid]
    if "feature_nz" in table and math.isfinite(float(row["feature_nz"])):
        axis = np.abs(row[["feature_nx", "feature_ny", "feature_nz"]].to_numpy(dtype=float))
        across = [a for k, a in enumerate("XYZ") if k != int(np.argmax(axis))]
        assert zone["axes"] == across
    if math.isfinite(float(row["x"])):
        assert feature["position"] == pytest.approx([float(row[c]) for c in ("x", "y", "z")])
    assert zone["components"] == [f"POSITION1 {a}" for a in zone["axes"]]
    assert not any(name == "POSITION1" for name, _ in scaffold_model([PLATE]).skipped)


def test_the_plate_questions_name_its_features_and_their_callouts() -> None:
    scaffold = scaffold_model([PLATE])
    raw = tomllib.loads(scaffold.text)
    notes = {fid: f["note"] for fid, f in raw["features"].items() if "note" in f}
    assert scaffold.questions and set(scaffold.questions) == {n.split(":")[0].split()[1] for n in notes.values()}
    for fid, note in notes.items():
        feature = raw["features"][fid]
        if "radius" in feature:  # a size cut by interpolation: which tool, and with what weight
            assert note.endswith("which tool cut it? (radius weight -2)") or "radius weight -1" in note, note
        else:
            assert note.endswith("which work offset (WKS) and which tool made it?"), note
    # the head lists every question with its feature and callouts
    for q in scaffold.questions:
        assert f"#   {q} " in scaffold.text
    head = scaffold.text.split("\n[process]")[0]
    assert "WIDTH2" in head and "POSITION1" in head
    model = load_model_text(scaffold.text)
    assert model.draft and model.multi_axis


def load_model_text(text: str) -> Any:
    return model_from_dict(tomllib.loads(text), "<scaffold>", text)


def test_a_distance_between_two_named_features_is_their_difference_signed_by_their_positions() -> None:
    geometry = {"feature": "cylinder", "feature_nx": 0.0, "feature_ny": 0.0, "feature_nz": 1.0}
    rows = [
        _row("A X", 70.0, -0.05, 0.05, x=70.0, y=10.0, z=5.0, nx=1.0, ny=0.0, nz=0.0, feature_id="A", **geometry),
        _row("B X", 30.0, -0.05, 0.05, x=30.0, y=10.0, z=5.0, nx=1.0, ny=0.0, nz=0.0, feature_id="B", **geometry),
        # measured from A to B in the report's order, but B lies at -X of A: the distance grows as A moves +X
        _row("A-B", 40.0, -0.05, 0.05, nx=1.0, ny=0.0, nz=0.0, between="A;B"),
        # no direction stated: the one from the positions (along X), the same sign rule
        _row("B-A", 40.0, -0.05, 0.05, between="B;A"),
    ]
    raw = tomllib.loads(scaffold_from_tables([("r.csv", _table(rows))]).text)
    dims = _dims(raw)
    fa, fb = next(iter(dims["A X"]["features"])), next(iter(dims["B X"]["features"]))
    assert dims["A-B"]["features"] == {fa: 1, fb: -1}
    assert dims["B-A"]["features"] == {fa: 1, fb: -1} and dims["B-A"]["axis"] == "X"
    # answered as made on one work offset, the distance has no work-offset term in the composite
    for f in (fa, fb):
        raw["features"][f] = {"wks": {"W1": 1}, "position": raw["features"][f]["position"]}
    del raw["process"]["draft"]
    rel = relation_matrices(model_from_dict(raw))
    col = rel.dimensions.index(next(k for k, d in raw["dimensions"].items() if d["name"] == "A-B"))
    on_w1 = [i for i, r in enumerate(rel.registers) if r.startswith("W1")]
    assert on_w1 and np.allclose(rel.composite[on_w1, col], 0.0)
    one = rel.dimensions.index(next(k for k, d in raw["dimensions"].items() if d["name"] == "A X"))
    assert rel.composite[rel.registers.index("W1.X"), one] == 1.0  # a location moves with its work offset


def test_a_one_axis_scaffold_gives_a_distance_no_work_offset_and_no_false_header() -> None:
    rows = [
        _row("Distance 1", 144.4, -0.5, 0.5),
        _row("Distance 2", 93.6, -0.5, 0.5),
        _row("Step", 12.0, -0.05, 0.05),
    ]
    scaffold = scaffold_from_tables([("box.csv", _table(rows))])
    raw = tomllib.loads(scaffold.text)
    assert raw["process"]["axis"] == "Z" and not scaffold.axes
    features = {d["name"]: raw["features"][next(iter(d["features"]))] for d in raw["dimensions"].values()}
    assert features["Distance 1"] == {"wks": {}, "tools": {}}
    assert features["Distance 2"] == {"wks": {}, "tools": {}}
    assert features["Step"]["wks"] == {"W1": 1}
    assert "the one most dimensions state" not in scaffold.text
    assert "no dimension states an axis" in scaffold.text


def test_the_cover_distances_get_no_g54_and_no_h1() -> None:
    raw = _raw(shared_path(*COVER))
    dims = _dims(raw)
    distances = [n for n in dims if n.startswith("DISTANCEBETWEEN")]
    assert distances
    for name in distances:
        assert dims[name]["features"] == {}, name  # the report names no ends: nothing moves it as written
    assert _dims(raw)["POSITION2"]["kind"] == "position"
    # one axis on request: a distance along Z still moves with neither G54 Z nor H1, and the header says why Z
    one = scaffold_model([shared_path(*COVER)], axis="Z")
    raw = tomllib.loads(one.text)
    for dim in raw["dimensions"].values():
        feature = raw["features"][next(iter(dim["features"]))]
        if dim["name"].startswith("DISTANCEBETWEEN"):
            assert feature == {"wks": {}, "tools": {}}, dim
    assert any(d["name"].startswith("DISTANCEBETWEEN") for d in raw["dimensions"].values())
    assert "the one most dimensions state" not in one.text and "kept: dimensions along Z" in one.text


def test_the_fair_box_has_no_geometry_and_gets_zones_questions_and_no_guess() -> None:
    scaffold = scaffold_model([shared_path(*FAIR_BOX)])
    raw = tomllib.loads(scaffold.text)
    dims = _dims(raw)
    zones = [d for d in dims.values() if d.get("kind") == "position"]
    assert len(zones) == 12 and all(z["axes"] == ["X", "Y"] for z in zones)
    assert all(dims[f"Distance {i}"]["features"] == {} for i in range(1, 7))
    assert "the one most dimensions state" not in scaffold.text
    assert all(f.get("wks", {}) == {} and "tools" not in f for f in raw["features"].values())


def test_the_scaffold_of_the_plate_loads(tmp_path: Path) -> None:
    path = tmp_path / "plate.toml"
    path.write_text(scaffold_model([PLATE]).text, encoding="utf-8")
    model = load_model(path)
    assert model.draft and any(d.zone for d in model.dimensions)
