"""``correct`` on multi-axis models (issue 23, Done when): generated held-out fixtures solved to the
optimum, checked against an independent solver on the true circle margins; the sample solves."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from multi_axis_fixtures import Fixture, independent_optimum, make_fixture, report_csv, true_margins

from setupfix.correction.offsets import offset_rows
from setupfix.model import ProcessModel, load_model
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, SolveOptions

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_reports" / "two_station_xyz"
MICRON = 0.001


def solve(tmp_path: Path, seed: int, objective: str | None = None) -> tuple[Fixture, ProcessModel, CycleCorrection]:
    fx = make_fixture(seed)
    (tmp_path / "model.toml").write_text(fx.text, encoding="utf-8")
    (tmp_path / "report.csv").write_text(report_csv(fx), encoding="utf-8")
    model = load_model(tmp_path / "model.toml")
    request = CorrectRequest(model, solve=SolveOptions(objective=objective, time_limit=120))  # a loaded box
    (cycle,) = correct_report(request, tmp_path / "report.csv").cycles
    return fx, model, cycle


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_generated_fixture_solved_to_the_independent_optimum(tmp_path: Path, seed: int) -> None:
    fx, model, cycle = solve(tmp_path, seed)
    assert model.register_ids == fx.registers
    best, best_values = independent_optimum(fx)
    raw = cycle.recommendation.result
    assert raw.status == "optimal"
    ours = cycle.problem.register_values(raw.x)
    # on the grids of their registers (rotation in steps of 0.0001°), within their limits
    assert np.allclose(np.round(ours / fx.steps), ours / fx.steps, atol=1e-6)
    assert np.all(np.abs(ours) <= fx.limits + 1e-12)
    ours_margin = true_margins(fx, ours).min()
    # the independent optimum is a lower bound of the true one, within the 720-gon's error of it
    slack = max(d["diameter"] / 2 - best for d in fx.dims if d["kind"] == "position") * (1 / np.cos(np.pi / 720) - 1)
    assert true_margins(fx, best_values).min() >= best - 1e-9
    assert ours_margin >= best - MICRON  # ours: exact on the polygon, the polygon within 1 µm of the circle
    assert ours_margin <= best + slack + 1e-9  # nobody beats the optimum
    assert cycle.problem.polygon <= MICRON
    # what is shown is the circle: margins, δ before/after and the zone rows of the JSON
    if cycle.verdict == "apply":
        applied = np.array([cycle.corrections[r] for r in fx.registers])
        assert cycle.margin_after == pytest.approx(true_margins(fx, applied).min(), abs=1e-9)
        data = cycle_json(cycle)
        assert data["margin_after"] == pytest.approx(true_margins(fx, applied).min(), abs=1e-6)
        zones = [row for row in data["dimensions"] if row["name"].endswith(("Z0", "Z1"))]
        assert len(zones) == 4
        for row in zones:
            d = next(d for d in fx.dims if d["name"] == row["name"])
            assert row["lower"] == 0 and row["upper"] == pytest.approx(d["diameter"] / 2)
            assert row["deviation"] == pytest.approx(np.hypot(*d["deviation"]), abs=1e-6)
            after = d["deviation"] + applied @ d["columns"]
            assert row["predicted"] == pytest.approx(np.hypot(*after), abs=1e-6)
            assert row["margin"] == pytest.approx(d["diameter"] / 2 - np.hypot(*after), abs=1e-6)
        assert set(data["corrections"]) == set(fx.registers)
    assert cycle.margin_before == pytest.approx(true_margins(fx, np.zeros(len(fx.registers))).min(), abs=1e-9)


def test_paper_objective_reaches_the_same_optimum(tmp_path: Path) -> None:
    fx, _, cycle = solve(tmp_path, 5, objective="paper")
    best, _ = independent_optimum(fx)
    ours = true_margins(fx, cycle.problem.register_values(cycle.recommendation.result.x)).min()
    assert best - MICRON <= ours <= best + 1e-5


def test_polygon_error_bound_against_the_circle() -> None:
    from setupfix.correction.zones import facet_rows, polygon_error, polygon_sides

    rng = np.random.default_rng(0)
    for radius in (0.02, 0.05, 0.3, 2.0):
        sides = polygon_sides(radius, MICRON)
        assert polygon_error(radius, sides) <= MICRON
        assert sides == 8 or polygon_error(radius, sides - 1) > MICRON  # the least such k
        v = rng.uniform(-1, 1, (500, 2))
        v *= radius * rng.uniform(0, 1, (500, 1)) / np.linalg.norm(v, axis=1, keepdims=True)
        dev, _ = facet_rows(np.zeros(2), np.zeros((0, 2)), sides)
        assert dev.shape == (sides,)
        _, comp = facet_rows(np.zeros(2), np.eye(2), sides)  # the facet rows' values for v: v @ comp
        polygon = radius - (v @ comp).max(axis=1)
        circle = radius - np.linalg.norm(v, axis=1)
        assert np.all(polygon <= circle + 1e-12)  # inscribed: never optimistic
        assert np.all(circle - polygon <= MICRON + 1e-12)


def test_offsets_rows_speak_components(tmp_path: Path) -> None:
    _, model, cycle = solve(tmp_path, 1)
    rows = offset_rows(model, cycle.corrections)
    assert [r.id for r in rows] == model.register_ids
    by = {r.id: r for r in rows}
    assert (by["W1.X"].axis, by["W1.X"].register, by["W1.X"].kind) == ("X", "G54", "wks")
    assert (by["W2.C"].axis, by["W2.C"].resolution) == ("C", 0.0001)
    assert (by["T1"].axis, by["T1"].register) == ("Z", "H1")
    assert (by["T1.R"].axis, by["T1.R"].register, by["T1.R"].kind) == ("R", "D1", "tool")
    assert by["W1.C"].cells()[6].count(".") == 1 and len(by["W1.C"].cells()[6].split(".")[1]) >= 4


@pytest.mark.slow
def test_sample_two_station_xyz_solves_through_the_cli() -> None:
    env_path = str(ROOT)
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "setupfix",
            "correct",
            "--model",
            str(SAMPLE / "model.toml"),
            str(SAMPLE / "cycle_01.csv"),
            "--json",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin"},
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["verdict"] == "apply" and data["in_tolerance"]
    assert set(data["corrections"]) == {
        "W1.X",
        "W1.Y",
        "W1.Z",
        "W1.C",
        "W2.X",
        "W2.Y",
        "W2.Z",
        "W2.C",
        "T1",
        "T1.R",
        "T2",
    }
    assert 0 < data["zone_polygon_error"] <= MICRON
    zone = next(r for r in data["dimensions"] if r["name"] == "P1 Hole 1")
    assert zone["lower"] == 0 and zone["upper"] == 0.05 and zone["predicted"] >= 0


def test_zone_with_one_component_missing_is_left_out(tmp_path: Path) -> None:
    fx = make_fixture(7)
    (tmp_path / "model.toml").write_text(fx.text, encoding="utf-8")
    text = report_csv(fx).splitlines()
    kept = [line for line in text if not line.startswith("P1 Z0 Y")]
    (tmp_path / "report.csv").write_text("\n".join(kept) + "\n", encoding="utf-8")
    (cycle,) = correct_report(CorrectRequest(load_model(tmp_path / "model.toml")), tmp_path / "report.csv").cycles
    assert "D4" not in {row["id"] for row in cycle.dimension_rows()}
    assert any("only one of its components" in n.message for n in cycle.notes)


@pytest.mark.slow
def test_history_store_keyed_by_component(tmp_path: Path) -> None:
    from setupfix.core.errors import MatchError
    from setupfix.store import open_store
    from setupfix.usecases.correct import load_request
    from setupfix.usecases.history import ImportRequest, import_history, record_recommendations

    model = load_model(SAMPLE / "model.toml")
    log = tmp_path / "log.csv"
    log.write_text(
        "timestamp,register,delta\n2026-11-21T09:00:00,W1.C,0.0012\n2026-11-21T09:00:00,T1.R,0.003\n", encoding="utf-8"
    )
    store_path = tmp_path / "h.db"
    with open_store(store_path) as store:
        summary = import_history(
            store, ImportRequest(reports=(str(SAMPLE / "cycle_01.csv"),), corrections=(str(log),), model=model)
        )
        assert summary.corrections == 2
        # a controller name shared by a WKS's components names none of them
        bad = tmp_path / "bad.csv"
        bad.write_text("timestamp,register,delta\n2026-11-22T09:00:00,G54,0.001\n", encoding="utf-8")
        with pytest.raises(MatchError, match=r"unknown register 'G54'.*W1\.X"):
            import_history(store, ImportRequest(corrections=(str(bad),), model=model))
    request = load_request(model, store=store_path, solve=SolveOptions(time_limit=120))
    (cycle,) = correct_report(request, SAMPLE / "cycle_02.csv").cycles
    with open_store(store_path) as store:
        record_recommendations(store, [cycle], model=SAMPLE / "model.toml", report=SAMPLE / "cycle_02.csv")
        (stored,) = store.recommendations()
    assert set(stored.result["corrections"]) == set(model.register_ids)
    assert stored.result["corrections"]["W1.C"] == pytest.approx(cycle.corrections["W1.C"])


ZONE_OUT: dict[str, Any] = {
    "process": {"name": "zone out", "axes": ["X", "Y"]},
    "wks": {"W1": {"register": "G54"}},
    "features": {"F1": {"wks": {"W1": 1}}, "F2": {"wks": {"W1": {"x": 1, "y": -1}}}},
    "dimensions": {
        "A": {"name": "A", "axis": "X", "features": {"F1": 1}, "nominal": 0, "lower": -0.02, "upper": 0.02},
        "H": {
            "name": "H",
            "kind": "position",
            "components": ["H X", "H Y"],
            "axes": ["X", "Y"],
            "diameter": 0.04,
            "features": {"F2": 1},
        },
    },
}


def _zone_out(tmp_path: Path) -> CycleCorrection:
    from setupfix.model import model_from_dict

    model = model_from_dict(ZONE_OUT)
    # A wants W1.X = −0.05; the zone wants W1.X = +0.05: no correction brings both in
    path = tmp_path / "r.csv"
    path.write_text(
        "characteristic,nominal,actual,deviation,part\nA,0,0.05,0.05,p\nH X,0,-0.05,-0.05,p\nH Y,0,0,0.0,p\n",
        encoding="utf-8",
    )
    (cycle,) = correct_report(CorrectRequest(model, solve=SolveOptions()), path).cycles
    return cycle


def test_triage_gives_a_zone_up_whole(tmp_path: Path) -> None:
    """The triage counts the zone once: A or H can be kept, not both; equal counts, equal margins 0.02 and
    equal norms 0.05, so the tie goes to the smallest k (W1.X = −0.05): A kept, the zone given up whole."""
    cycle = _zone_out(tmp_path)
    raw = cycle.recommendation.result
    assert raw.status == "optimal"
    assert raw.x.tolist() == pytest.approx([-0.05, 0.0])
    facets = {d for d in cycle.problem.dimension_ids if d.startswith("H#")}
    assert set(raw.given_up) == facets  # every facet of the zone, none of A
    assert raw.triage is not None and raw.triage.kept == 1
    assert raw.triage.given_up == {"H": pytest.approx(0.02 - 0.1)}  # the circle's margin at ‖(−0.1, 0)‖
    assert raw.margin_after == pytest.approx(0.02)  # δ over A alone
    assert "1 dimension(s) given up (H)" in raw.message


def test_triage_keeps_a_zone_whole_and_applies(tmp_path: Path) -> None:
    """With the zone's diameter 0.06 (margin up to 0.03 kept, against A's 0.02) the leximin of the kept
    margins keeps the zone: A is given up, the correction W1.X = +0.05 is applied, the zone in its circle."""
    from setupfix.model import model_from_dict

    doc = {**ZONE_OUT, "dimensions": {**ZONE_OUT["dimensions"], "H": {**ZONE_OUT["dimensions"]["H"], "diameter": 0.06}}}
    model = model_from_dict(doc)
    path = tmp_path / "r.csv"
    path.write_text(
        "characteristic,nominal,actual,deviation,part\nA,0,0.05,0.05,p\nH X,0,-0.05,-0.05,p\nH Y,0,0,0.0,p\n",
        encoding="utf-8",
    )
    (cycle,) = correct_report(CorrectRequest(model, solve=SolveOptions()), path).cycles
    assert cycle.recommendation.result.status == "optimal"
    assert cycle.verdict == "apply" and cycle.given_up == ("A",)
    assert cycle.corrections["W1.X"] == pytest.approx(0.05) and cycle.corrections["W1.Y"] == 0
    rows = {row["id"]: row for row in cycle.dimension_rows()}
    assert rows["H"]["margin"] == pytest.approx(0.03)  # the circle's, centred
    assert cycle.margin_after == pytest.approx(0.03)  # δ over the kept dimensions: the zone
    assert all("#" not in d for r in cycle.rules for d in r.dimensions)


def test_triage_with_a_zone_given_up_applies(tmp_path: Path) -> None:
    cycle = _zone_out(tmp_path)
    assert cycle.verdict == "apply"
    assert cycle.corrections["W1.X"] == pytest.approx(-0.05) and cycle.corrections["W1.Y"] == 0
    assert cycle.given_up == ("H",)
    assert not any(r.rule == "no_harm" and r.dimensions for r in cycle.rules)
    assert all("#" not in d for r in cycle.rules for d in r.dimensions)
    assert cycle.margin_after == pytest.approx(
        min(row["margin"] for row in cycle.dimension_rows() if row["id"] not in cycle.given_up)
    )


def test_view_and_text_rows_speak_components(tmp_path: Path) -> None:
    from setupfix.views.correction import dimension_rows, register_rows, summary
    from setupfix.views.present import format_correction

    _, model, cycle = solve(tmp_path, 2)
    regs = register_rows(cycle, current={"W1.C": 0.5, "G54": 9.0})
    assert [r.id for r in regs] == model.register_ids
    by = {r.id: r for r in regs}
    assert by["W1.C"].component == "C" and by["W1.C"].current == 0.5
    assert by["W1.X"].current is None  # G54 names every component of W1: none of them
    assert by["W1.C"].delta == pytest.approx(cycle.corrections["W1.C"])
    names = [r.name for r in dimension_rows(cycle)]
    assert len(names) == len(set(names)) == len(model.dimensions)
    assert summary(cycle).margin_after == pytest.approx(cycle.margin_after)
    text = format_correction(cycle)
    assert "per register component" in text
    line = next(t for t in text.splitlines() if t.strip().startswith("W1.C"))
    assert len(line.split()[2].split(".")[1]) == 4  # degrees on the 0.0001° grid
