"""A position zone whose components are also dimensions (issue 37 item 6): the spec allows it
(``process-model.md``, multi-axis) and drawings do it — a hole's position ⌀0.1 and its X alone ±0.03.
One report row feeds both; the correction is checked against a brute force over the register grid."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from setupfix.core.errors import ModelError
from setupfix.model import load_model
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, SolveOptions

LIMIT, STEP = 0.03, 0.001


def model_text(x_tol: float, y_dim: bool = False) -> str:
    return f"""
[process]
name = "a hole's zone and its X"
axes = ["X", "Y"]
unit = "mm"
resolution = {STEP}
limit = {LIMIT}

[wks.W1]
register = "G54"

[features.HOLE]
wks = {{ W1 = 1 }}
position = [40.0, 25.0, 0.0]

[features.EDGE]
wks = {{ W1 = 1 }}

[dimensions.H]
name = "Hole"
features = {{ HOLE = 1 }}
kind = "position"
components = ["Hole X", "Hole Y"]
axes = ["X", "Y"]
diameter = 0.1

[dimensions.HX]
name = "Hole X"
features = {{ HOLE = 1 }}
axis = "X"
nominal = 0
lower = -{x_tol}
upper = {x_tol}

[dimensions.E]
name = "Edge Y"
features = {{ EDGE = 1 }}
axis = "Y"
nominal = 0
lower = -0.01
upper = 0.05
""" + (
        """
[dimensions.HY]
name = "Hole Y"
features = { HOLE = 1 }
axis = "Y"
nominal = 0
lower = -0.015
upper = 0.025
"""
        if y_dim
        else ""
    )


def true_margins(dx: float, dy: float, de: float, tx: float, ty: float, x_tol: float, y_dim: bool) -> list[float]:
    """Every dimension's margin after the shift (tx, ty) of W1, straight from the spec's formulas."""
    out = [
        0.05 - float(np.hypot(dx + tx, dy + ty)),  # zone: R − ‖δ + d‖
        min(dx + tx + x_tol, x_tol - dx - tx),
        min(de + ty + 0.01, 0.05 - de - ty),
    ]
    if y_dim:
        out.append(min(dy + ty + 0.015, 0.025 - dy - ty))
    return out


CASES = [  # deviations of Hole X, Hole Y, Edge Y; X's tolerance; a Y dimension too
    (0.045, 0.03, 0.04, 0.04, False),
    (0.045, 0.03, 0.02, 0.02, False),
    (-0.02, 0.04, 0.045, 0.03, True),
    (0.01, -0.035, 0.0, 0.025, True),
]


@pytest.mark.parametrize(("dx", "dy", "de", "x_tol", "y_dim"), CASES)
def test_zone_and_its_component_dimensions_match_the_brute_force(
    tmp_path: Path, dx: float, dy: float, de: float, x_tol: float, y_dim: bool
) -> None:
    (tmp_path / "m.toml").write_text(model_text(x_tol, y_dim))
    report = tmp_path / "r.csv"
    report.write_text(f"characteristic,nominal,actual\nHole X,0,{dx}\nHole Y,0,{dy}\nEdge Y,0,{de}\n")
    model = load_model(tmp_path / "m.toml")
    (cycle,) = correct_report(CorrectRequest(model, solve=SolveOptions(objective="paper")), report).cycles
    assert not cycle.part.absent and not cycle.part.unmatched  # one row fed the zone and the dimension
    doc = cycle_json(cycle)
    tx, ty = doc["corrections"]["W1.X"], doc["corrections"]["W1.Y"]
    got = true_margins(dx, dy, de, tx, ty, x_tol, y_dim)
    rows = {r["id"]: r for r in doc["dimensions"]}
    assert rows["HX"]["deviation"] == pytest.approx(dx) and rows["HX"]["predicted"] == pytest.approx(dx + tx)
    assert rows["H"]["predicted"] == pytest.approx(np.hypot(dx + tx, dy + ty), abs=1e-9)
    assert doc["margin_after"] == pytest.approx(min(got), abs=1e-9)
    grid = np.round(np.arange(-LIMIT, LIMIT + STEP / 2, STEP), 9)
    best = max(min(true_margins(dx, dy, de, a, b, x_tol, y_dim)) for a, b in itertools.product(grid, grid))
    polygon = doc["zone_polygon_error"]  # the zone is solved on an inscribed polygon: at most this much lost
    assert best - polygon - 1e-9 <= min(got) <= best + 1e-9
    assert doc["verdict"] == "apply"


def test_a_component_of_two_zones_is_still_refused(tmp_path: Path) -> None:
    text = (
        model_text(0.03)
        + """
[dimensions.H2]
name = "Hole again"
features = { HOLE = 1 }
kind = "position"
components = ["Hole X", "Hole Y 2"]
axes = ["X", "Y"]
diameter = 0.2
"""
    )
    (tmp_path / "m.toml").write_text(text)
    with pytest.raises(ModelError, match="also a component of position zone H"):
        load_model(tmp_path / "m.toml")


def test_a_name_of_two_dimensions_is_still_refused(tmp_path: Path) -> None:
    text = model_text(0.03).replace('name = "Edge Y"', 'name = "Hole X"')
    (tmp_path / "m.toml").write_text(text)
    with pytest.raises(ModelError, match="also used by dimension HX"):
        load_model(tmp_path / "m.toml")
