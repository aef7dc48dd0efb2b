"""CorrectionProblem of a multi-axis model: rotations scaled onto the one grid, zones as facets."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from setupfix.correction.relation import relation_matrices
from setupfix.model import PartMeasurement, ProcessModel, match_parts, model_from_dict
from setupfix.optimize import CorrectionProblem, get_optimizer

DOC = {
    "process": {
        "name": "rot",
        "axes": ["X", "Y"],
        "rotation": True,
        "resolution": 0.001,
        "limit": 0.1,
        "rotation_limit": 0.0333,
        "rotation_resolution": 0.0001,
    },
    "wks": {"W1": {"register": "G54"}},
    "features": {
        "F1": {"wks": {"W1": 1}, "position": [100.0, 0.0, 0.0]},
        "F2": {"wks": {"W1": 1}, "position": [0.0, 50.0, 0.0]},
    },
    "dimensions": {
        "DY": {"name": "Y at F1", "axis": "Y", "features": {"F1": 1}, "nominal": 0, "lower": -0.05, "upper": 0.05},
        "DX": {"name": "X at F2", "axis": "X", "features": {"F2": 1}, "nominal": 0, "lower": -0.05, "upper": 0.05},
        "DP": {
            "name": "hole",
            "kind": "position",
            "components": ["hole X", "hole Y"],
            "axes": ["X", "Y"],
            "diameter": 0.1,
            "features": {"F1": 1},
        },
    },
}


def part(model: ProcessModel, values: dict[str, float]) -> PartMeasurement:
    table = pd.DataFrame({"characteristic": list(values), "deviation": list(values.values()), "unit": "mm"})
    (p,) = match_parts(model, table)
    return p


def test_rotation_column_bounds_and_values_are_scaled_in_one_place() -> None:
    model = model_from_dict(DOC)
    p = part(model, {"Y at F1": 0.02, "X at F2": 0.01})
    problem = CorrectionProblem.from_part(model, p)
    C = relation_matrices(model).composite  # real units: mm per degree for W1.C
    scale = problem.scale
    assert scale is not None and scale.tolist() == [1.0, 1.0, 0.1]  # ρ/h = 0.0001/0.001
    assert problem.composite[2] == pytest.approx(C[2, [0, 1]] * 0.1)
    # 0.0333° = 333 rotation steps → ±0.333 problem units on the 0.001 grid
    assert problem.ub[2] == pytest.approx(0.333) and problem.lb[2] == pytest.approx(-0.333)
    assert problem.register_values(np.array([0.0, 0.0, 0.007])) == pytest.approx([0, 0, 0.0007])
    # a problem step is a rotation step: the grid solution is on 0.0001°
    result = get_optimizer("exact").solve(problem)
    theta = problem.register_values(result.x)[2]
    assert round(theta / 0.0001) * 0.0001 == pytest.approx(theta, abs=1e-12)
    # Y at F1 moves by θ·π/180·100 per degree: −0.02 needs θ ≈ −0.01146°
    assert abs(theta) <= 0.0333 + 1e-12


def test_zone_becomes_facets_mapped_back_to_one_dimension() -> None:
    model = model_from_dict(DOC)
    p = part(model, {"Y at F1": 0.0, "X at F2": 0.0, "hole X": 0.03, "hole Y": -0.04})
    assert p.deviation[2] == pytest.approx(0.05)
    problem = CorrectionProblem.from_part(model, p)
    assert problem.circles is not None and problem.circles.ids == ("DP",)
    k = problem.circles.sides[0]
    assert len(problem.dimension_ids) == 2 + k and problem.rows is not None
    assert problem.dimension_of(problem.dimension_ids) == ("DY", "DX", "DP")
    assert 0 < problem.polygon <= 0.001
    ids, dev, _, lower, upper, margin = problem.dimension_table(np.zeros(3))
    assert ids == ("DY", "DX", "DP")
    assert (dev[2], lower[2], upper[2], margin[2]) == pytest.approx((0.05, 0.0, 0.05, 0.0))
    x = np.array([-0.03, 0.04, 0.0])
    assert problem.dimension_table(x)[5][2] == pytest.approx(0.05)
    # the facet rows never report a better margin than the circle
    assert problem.margins(x)[2:].min() <= 0.05 + 1e-12
