"""The multi-axis relation (spec *Multi-axis models*) checked by hand on a small model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from setupfix.correction.relation import feature_shifts, projected_composite, relation_matrices
from setupfix.model import model_from_dict

DOC = {
    "process": {"name": "hand", "axes": ["X", "Y", "Z"], "rotation": True},
    "wks": {"W1": {"register": "G54"}},
    "tools": {"T1": {"register": "H1", "radius": "D1"}},
    "features": {
        "F1": {"wks": {"W1": 1}, "position": [30.0, 40.0, 5.0], "tools": {"T1": 1}},
        "F2": {"wks": {"W1": {"x": -1, "y": 1, "z": -1, "c": 2}}, "position": [-10.0, 0.0, 0.0], "radius": {"T1": 1}},
        "F3": {"wks": {"W1": 1}, "position": [0.0, 20.0, 0.0], "radius": {"T1": -1}},
    },
    "dimensions": {
        "DZ": {"axis": "Z", "features": {"F1": 1}, "nominal": 0, "lower": -0.1, "upper": 0.1},
        "DN": {
            "direction": [0.6, 0.8, 0.0],
            "features": {"F1": 1, "F2": -1},
            "nominal": 0,
            "lower": -0.1,
            "upper": 0.1,
        },
        "DS": {"kind": "size", "features": {"F2": 1, "F3": -1}, "nominal": 10, "lower": -0.1, "upper": 0.1},
        "DP": {
            "kind": "position",
            "components": ["P X", "P Y"],
            "axes": ["X", "Y"],
            "diameter": 0.2,
            "features": {"F1": 1},
        },
    },
}


def test_composite_by_hand() -> None:
    model = model_from_dict(DOC)
    assert model.register_ids == ["W1.X", "W1.Y", "W1.Z", "W1.C", "T1", "T1.R"]
    rel = relation_matrices(model)
    C = rel.composite
    k = math.pi / 180
    # s × x_f with s = Z: (−y, x, 0)
    lever1 = np.array([-40.0, 30.0, 0.0]) * k
    lever2 = np.array([0.0, -10.0, 0.0]) * k
    # DZ = z of F1: W1.Z + T1 (length along s = Z); rotation moves F1 in the XY plane only
    assert C[:, 0] == pytest.approx([0, 0, 1, 0, 1, 0])
    # DN = n·(p1 − p2), n = (0.6, 0.8, 0); F2 has x = −1, y = 1, c = 2; radius: 0·(F1) − 1·(+1)
    n = np.array([0.6, 0.8, 0.0])
    assert C[0, 1] == pytest.approx(0.6 - (-0.6))
    assert C[1, 1] == pytest.approx(0.8 - 0.8)
    assert C[2, 1] == pytest.approx(0.0)
    assert C[3, 1] == pytest.approx(n @ lever1 - 2 * (n @ lever2))
    assert C[4, 1] == pytest.approx(0.0)
    assert C[5, 1] == pytest.approx(-1.0)
    # DS: a size keeps only radius terms: 1·(+1) − 1·(−1) = 2
    assert C[:, 2] == pytest.approx([0, 0, 0, 0, 0, 2])
    # DP: a zone's column is 0; its component columns are x and y of p_F1
    assert C[:, 3] == pytest.approx(0.0)
    assert rel.zones is not None
    assert rel.zones[:, 3, 0] == pytest.approx([1, 0, 0, lever1[0], 0, 0])
    assert rel.zones[:, 3, 1] == pytest.approx([0, 1, 0, lever1[1], 0, 0])
    assert rel.zones[:, :3, :] == pytest.approx(0.0)


def test_rotation_moves_a_feature_by_s_cross_x() -> None:
    positions = np.array([[3.0, 4.0, 7.0]])
    rotation = np.array([[1.0]])
    zero = np.zeros((1, 1))
    p = feature_shifts(zero, np.zeros((1, 3)), rotation, positions, zero, np.array([0.0, 0.0, 1.0]))
    assert p[0, 0] == pytest.approx(np.cross([0, 0, 1], [3, 4, 7]) * math.pi / 180)
    # spindle X: s × x = (0, −z, y)
    p = feature_shifts(zero, np.zeros((1, 3)), rotation, positions, zero, np.array([1.0, 0.0, 0.0]))
    assert p[0, 0] == pytest.approx(np.array([0.0, -7.0, 4.0]) * math.pi / 180)


def test_projected_composite_is_the_spec_sum() -> None:
    rng = np.random.default_rng(3)
    shifts = rng.normal(size=(4, 5, 3))
    radius = rng.normal(size=(4, 5))
    r_fd = rng.normal(size=(5, 3))
    n = rng.normal(size=(3, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    size = np.array([False, True, False])
    got = projected_composite(shifts, radius, r_fd, n, size)
    for r in range(4):
        for q in range(3):
            want = sum(r_fd[f, q] * ((0 if size[q] else n[q] @ shifts[r, f]) + radius[r, f]) for f in range(5))
            assert got[r, q] == pytest.approx(want)


def test_one_axis_relation_unchanged() -> None:
    doc = {
        "process": {"name": "one"},
        "wks": {"W1": {}},
        "tools": {"T1": {}},
        "features": {"F1": {"wks": {"W1": 1}, "tools": {"T1": -1}}},
        "dimensions": {"D1": {"features": {"F1": 2}, "nominal": 0, "lower": -0.1, "upper": 0.1}},
    }
    rel = relation_matrices(model_from_dict(doc))
    assert rel.multi is None and rel.zones is None
    assert rel.composite == pytest.approx(np.array([[2.0], [-2.0]]))
