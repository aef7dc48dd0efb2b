"""``model map``: a scaffold's questions answered, written into the model, and ``correct`` on the result.

The predictions ``correct`` makes after the answers are checked against a hand computation
here: the TOML the answers wrote is read as plain data and every dimension's change is
summed with numpy from the spec's equations (process-model.md, multi-axis: p_f = Σ A_fW t_W +
Σ w_fT h_T s, d_q = Σ w_qf (n_q · p_f + Σ ρ_fT r_T); a zone's radial distance
‖δ + d‖), not with the project's relation code.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SAMPLES

import parsers
from setupfix.core.errors import ModelError, ParseError, SourceLocation
from setupfix.model import load_model
from setupfix.usecases.correct import correct_report
from setupfix.usecases.model_init import scaffold_model
from setupfix.usecases.model_map import Answer, answer_questions, map_listing, parse_answer, read_answers
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, CycleOptions

PLATE = SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF"
AXES = ("X", "Y", "Z")
HERE = SourceLocation("test")

#: A part with a top face, a hole located in X and Y with its diameter and position, a second hole's
#: diameter and the distance between the two holes (the geometry columns a reader states).
REPORT = """\
characteristic,nominal,actual,lower,upper,part,x,y,z,nx,ny,nz,feature,size,side,feature_id,between,feature_nx,feature_ny,feature_nz
TOP Z,20,20.012,-0.05,0.05,{p},10,10,20,0,0,1,plane,,,TOP,,0,0,1
HOLE1 X,30,{hx},-0.05,0.05,{p},30,40,20,1,0,0,cylinder,,,HOLE1,,0,0,1
HOLE1 Y,40,{hy},-0.05,0.05,{p},30,40,20,0,1,0,cylinder,,,HOLE1,,0,0,1
HOLE1 DIA,8,7.99,-0.03,0.03,{p},30,40,20,,,,cylinder,diameter,inner,HOLE1,,0,0,1
HOLE1 POSITION,0,0.045,,0.1,{p},30,40,20,,,,cylinder,,,HOLE1,,0,0,1
HOLE2 DIA,8,8.004,-0.03,0.03,{p},70,40,20,,,,cylinder,diameter,inner,HOLE2,,0,0,1
H1-H2 DIST,40,{d},-0.05,0.05,{p},,,,1,0,0,,,,,HOLE1;HOLE2,,,
"""


def _report(tmp_path: Path) -> Path:
    path = tmp_path / "part.csv"
    parts = [("1", "30.02", "39.99", "40.03"), ("2", "30.035", "40.02", "39.98")]
    text = REPORT.format(p="1", hx=parts[0][1], hy=parts[0][2], d=parts[0][3])
    for p, hx, hy, d in parts[1:]:
        text += "".join(REPORT.format(p=p, hx=hx, hy=hy, d=d).splitlines(keepends=True)[1:])
    path.write_text(text, encoding="utf-8")
    return path


def _scaffold(report: Path, tmp_path: Path) -> Path:
    model = tmp_path / "model.toml"
    model.write_text(scaffold_model([report]).text, encoding="utf-8")
    return model


def _unit(axis: str) -> np.ndarray:
    return np.array([1.0 if a == axis else 0.0 for a in AXES])


def hand_predictions(
    raw: dict[str, Any], corrections: dict[str, float], deviations: dict[str, float]
) -> dict[str, float]:
    """Every dimension's predicted deviation (a zone: its radial distance) from the model as plain data."""
    spindle = _unit(raw["process"].get("spindle", "Z"))
    shift: dict[str, np.ndarray] = {}
    radius: dict[str, float] = {}
    for fid, f in raw["features"].items():
        p = np.zeros(3)
        for wid, w in f.get("wks", {}).items():
            t = np.array([corrections.get(f"{wid}.{a}", 0.0) for a in AXES])
            p += float(w) * t
        for tid, w in f.get("tools", {}).items():
            p += float(w) * corrections.get(tid, 0.0) * spindle
        shift[fid] = p
        radius[fid] = sum(float(w) * corrections.get(f"{tid}.R", 0.0) for tid, w in f.get("radius", {}).items())
    out = {}
    for dim in raw["dimensions"].values():
        if dim.get("kind") == "position":
            if not all(c in deviations for c in dim["components"]):
                continue  # absent from the report: no prediction
            a, b = (AXES.index(x) for x in dim["axes"])
            da = sum(float(w) * shift[f][a] for f, w in dim["features"].items())
            db = sum(float(w) * shift[f][b] for f, w in dim["features"].items())
            ca, cb = (deviations[c] for c in dim["components"])
            out[dim["name"]] = math.hypot(ca + da, cb + db)
            continue
        if dim.get("kind") == "size":
            change = sum(float(w) * radius[f] for f, w in dim["features"].items())
        else:
            n = _unit(dim["axis"]) if "axis" in dim else np.asarray(dim.get("direction", spindle), dtype=float)
            change = sum(float(w) * (float(n @ shift[f]) + radius[f]) for f, w in dim["features"].items())
        out[dim["name"]] = deviations[dim["name"]] + change
    return out


def _check_predictions(model_path: Path, cycle: CycleCorrection, deviations: dict[str, float]) -> int:
    raw = tomllib.loads(model_path.read_text(encoding="utf-8"))
    hand = hand_predictions(raw, cycle.corrections, deviations)
    checked = 0
    for row in cycle.dimension_rows():
        assert row["predicted"] == pytest.approx(hand[row["name"]], abs=1e-9), row["name"]
        checked += 1
    return checked


def _deviations(report: Path, part: str) -> dict[str, float]:
    table = parsers.read_report(report).table
    rows = table[table["part"].astype(str) == part]
    return {str(n): float(d) for n, d in zip(rows["characteristic"], rows["deviation"], strict=True)}


def test_answers_write_relations_registers_and_lift_the_draft(tmp_path: Path) -> None:
    model = _scaffold(_report(tmp_path), tmp_path)
    listing = map_listing(model)
    assert [q.label for q in listing.questions] == ["TOP", "HOLE1", "HOLE2"]
    assert all(q.needs_wks for q in listing.questions)
    hole1 = listing.questions[1]
    assert set(hole1.callouts) == {"HOLE1 X", "HOLE1 Y", "HOLE1 DIA", "HOLE1 POSITION", "H1-H2 DIST"}
    result = answer_questions(model, [Answer("TOP", "G54", "T1", HERE), Answer("HOLE*", "G54", "T7", HERE)])
    assert result.remaining == () and result.draft_lifted and not result.draft
    assert set(result.added) == {"T1 H1", "T7 H7 D7"}
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    assert "draft" not in raw["process"]
    features = raw["features"]
    assert all("note" not in f for f in features.values())
    located = [f for f in features.values() if "wks" in f]
    sizes = [f for f in features.values() if "radius" in f]
    assert all(f["wks"] == {"W1": 1} for f in located) and len(sizes) == 2
    # a tool length moves only what is measured along the spindle: the top face, not the holes' X/Y
    assert [f.get("tools") for f in located] == [{"T1": 1}, None, None]
    assert all(f["radius"] == {"T7": -2} for f in sizes)
    assert raw["tools"]["T7"] == {"register": "H7", "radius": "D7"} and raw["tools"]["T1"] == {"register": "H1"}
    assert not load_model(model).draft
    assert "# TOP (a plane at 10, 10, 20)" in model.read_text(encoding="utf-8")  # comments stay


def test_part_answers_keep_the_draft_and_a_later_answer_lifts_it(tmp_path: Path) -> None:
    model = _scaffold(_report(tmp_path), tmp_path)
    first = answer_questions(model, parse_answer("Q1=G54,T1", HERE))
    assert first.remaining == ("Q2", "Q3") and first.draft and not first.draft_lifted
    assert load_model(model).draft
    assert [q.name for q in map_listing(model).questions] == ["Q2", "Q3"]
    second = answer_questions(model, parse_answer("*=G55,5", HERE))
    assert second.draft_lifted and {w for _, w, _ in second.answered} == {"W2"}
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    assert raw["wks"]["W2"] == {"register": "G55"} and "T5" in raw["tools"]


def test_a_csv_of_answers_and_a_station_group(tmp_path: Path) -> None:
    model = _scaffold(_report(tmp_path), tmp_path)
    csv = tmp_path / "answers.csv"
    csv.write_text("feature,wks,tool\nTOP,G54,T1\nHOLE1 DIA,G54,T3\nF5,G54,none\n", encoding="utf-8")
    answers = read_answers(csv)
    assert [a.where.line for a in answers] == [2, 3, 4]
    result = answer_questions(model, answers)
    assert result.remaining == () and ("Q3", "W1", "none") in result.answered
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    hole2 = [f for f in raw["features"].values() if "HOLE2" in str(f)] or [
        raw["features"][k] for k in raw["features"] if k in ("F4", "F5")
    ]
    assert {"wks": {"W1": 1}, "position": [70.0, 40.0, 20.0]} in hole2  # located, moved by no tool
    assert {"radius": {}, "position": [70.0, 40.0, 20.0]} in hole2


@pytest.mark.parametrize(
    ("answers", "message"),
    [
        (["NOPE=G54,T1"], "selects no open question"),
        (["Q1=,T1"], "no work offset given"),
        (["Q1=G54,"], "no tool given"),
        (["Q1=G54,T1", "TOP=G55,T1"], "answered twice, differently"),
        (["Q1=G5 4,T1"], "expected a register"),
        (["Q1=G54,drill"], "expected a tool"),
        (["Q1 G54 T1"], "expected SELECTOR"),
    ],
)
def test_refused_answers_name_their_place_and_write_nothing(tmp_path: Path, answers: list[str], message: str) -> None:
    model = _scaffold(_report(tmp_path), tmp_path)
    before = model.read_bytes()
    with pytest.raises(ParseError, match=message) as info:
        parsed = [a for i, spec in enumerate(answers) for a in parse_answer(spec, SourceLocation(f"--answer #{i + 1}"))]
        answer_questions(model, parsed)
    assert "--answer #" in str(info.value)
    assert model.read_bytes() == before


def test_a_model_that_does_not_load_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[process]\nname = 1\n", encoding="utf-8")
    with pytest.raises(ModelError):
        map_listing(bad)
    with pytest.raises(ModelError, match="no such model file"):
        map_listing(tmp_path / "missing.toml")


def test_after_the_answers_correct_predicts_what_a_hand_computation_gives(tmp_path: Path) -> None:
    """Two setups: the top and hole 1 on G54, hole 2 on G55 — the distance between the holes then moves with
    both work offsets (it does not when both holes are on one); the sizes with the tool radius."""
    report = _report(tmp_path)
    model = _scaffold(report, tmp_path)
    answer_questions(
        model,
        [*parse_answer("TOP=G54,T1", HERE), *parse_answer("HOLE1=G54,T2", HERE), *parse_answer("HOLE2=G55,T3", HERE)],
    )
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    distance = next(d for d in raw["dimensions"].values() if d["name"] == "H1-H2 DIST")
    wks_of = {w: next(iter(raw["features"][f]["wks"])) for f, w in distance["features"].items()}
    assert wks_of == {1: "W2", -1: "W1"}  # hole 2 (on G55) minus hole 1 (on G54)
    outcome = correct_report(CorrectRequest(load_model(model)), report)
    assert len(outcome.cycles) == 2
    for cycle, part in zip(outcome.cycles, ("1", "2"), strict=True):
        assert cycle.solved
        deviations = _deviations(report, part)
        assert _check_predictions(model, cycle, deviations) == 7
        # the hole's location moves with G54 alone; the distance with G55 X minus G54 X
        c = cycle.corrections
        rows = {r["name"]: r for r in cycle.dimension_rows()}
        assert rows["H1-H2 DIST"]["predicted"] == pytest.approx(
            deviations["H1-H2 DIST"] + c["W2.X"] - c["W1.X"], abs=1e-12
        )
        assert rows["HOLE1 DIA"]["predicted"] == pytest.approx(deviations["HOLE1 DIA"] - 2 * c["T2.R"], abs=1e-12)
        zone = math.hypot(deviations["HOLE1 X"] + c["W1.X"], deviations["HOLE1 Y"] + c["W1.Y"])
        assert rows["HOLE1 POSITION"]["predicted"] == pytest.approx(zone, abs=1e-12)
        assert rows["TOP Z"]["predicted"] == pytest.approx(deviations["TOP Z"] + c["W1.Z"] + c["T1"], abs=1e-12)


def test_the_plate_answered_by_groups_gives_corrections_a_hand_computation_confirms(tmp_path: Path) -> None:
    model = _scaffold(PLATE, tmp_path)
    answer_questions(model, [*parse_answer("DIAMETER5*=,T2", HERE), *parse_answer("*=G54,T4", HERE)])
    loaded = load_model(model)
    assert not loaded.draft
    part = "PLATE_RESULTS_A02_NIST_MTC_CRADA_PLATE_ORIGIN_NIKON_SCAN"
    outcome = correct_report(CorrectRequest(loaded, cycles=CycleOptions(part=part)), PLATE)
    (cycle,) = outcome.cycles
    assert cycle.verdict in ("apply", "hold") and cycle.solved
    deviations = _deviations(PLATE, cycle.part.part)
    assert _check_predictions(model, cycle, deviations) >= 25
    # the sizes of the holes answered with T2 move with D2 alone, by -2 per unit of radius
    c = cycle.corrections
    rows = {r["name"]: r for r in cycle.dimension_rows()}
    assert rows["DIAMETER5 (2)"]["predicted"] == pytest.approx(deviations["DIAMETER5 (2)"] - 2 * c["T2.R"], abs=1e-12)
    assert rows["DISTANCEBETWEEN5"]["predicted"] == pytest.approx(deviations["DISTANCEBETWEEN5"], abs=1e-12)


def test_the_head_lists_only_open_questions_and_init_takes_answers_too(tmp_path: Path) -> None:
    report = _report(tmp_path)
    model = _scaffold(report, tmp_path)
    assert "# Questions (3; " in model.read_text(encoding="utf-8")
    answer_questions(model, parse_answer("HOLE2=G54,T3", HERE))
    text = model.read_text(encoding="utf-8")
    assert "# Questions (2; " in text and "#   Q3 " not in text and "#   Q1 " in text
    answer_questions(model, parse_answer("*=G54,T1", HERE))
    assert "# Questions" not in model.read_text(encoding="utf-8")
    # the same answers given to model init: the same relations, still a draft
    answers = [a for spec in ("HOLE2=G54,T3", "*=G54,T1") for a in parse_answer(spec, HERE)]
    scaffold = scaffold_model([report], answers=answers)
    assert scaffold.questions == () and "# Questions" not in scaffold.text
    at_init = tomllib.loads(scaffold.text)
    mapped = tomllib.loads(model.read_text(encoding="utf-8"))
    assert at_init["process"]["draft"] is True and "draft" not in mapped["process"]
    assert at_init["features"] == mapped["features"] and at_init["tools"] == mapped["tools"]


def test_a_station_is_answered_as_a_group_and_its_features_are_its_own(tmp_path: Path) -> None:
    """One feature name at two fixture stations is two workpieces: two questions, answered per station."""
    head = "characteristic,nominal,actual,lower,upper,part,station,x,y,z,nx,ny,nz,feature,feature_id\n"
    rows = [
        f"{name},{nominal},{nominal + 0.01},-0.05,0.05,1,{station},0,0,{z},{n},plane,{fid}\n"
        for station in ("P1", "P2")
        for name, nominal, z, n, fid in (("TOP Z", 20, 20, "0,0,1", "TOP"), ("SIDE X", 50, 10, "1,0,0", "SIDE"))
    ]
    report = tmp_path / "stations.csv"
    report.write_text(head + "".join(rows), encoding="utf-8")
    model = _scaffold(report, tmp_path)
    listing = map_listing(model)
    assert [(q.label, q.features[0].groups) for q in listing.questions] == [
        ("TOP", ("P1",)),
        ("SIDE", ("P1",)),
        ("TOP", ("P2",)),
        ("SIDE", ("P2",)),
    ]
    result = answer_questions(model, [*parse_answer("group:P2=G55,T1", HERE), *parse_answer("*=G54,T1", HERE)])
    assert {q: w for q, w, _ in result.answered} == {"Q1": "W1", "Q2": "W1", "Q3": "W2", "Q4": "W2"}
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    by_station = {
        (d["group"], d["name"]): raw["features"][next(iter(d["features"]))] for d in raw["dimensions"].values()
    }
    assert by_station[("P2", "TOP Z")] == {"wks": {"W2": 1}, "tools": {"T1": 1}, "position": [0.0, 0.0, 20.0]}
    assert by_station[("P1", "SIDE X")] == {"wks": {"W1": 1}, "position": [0.0, 0.0, 10.0]}
