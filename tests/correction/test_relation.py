"""Relation matrices and prediction against the paper's equations and printed matrices."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.correction.relation import (
    null_space_directions,
    predict_dimensions,
    predict_features,
    relation_matrices,
)
from setupfix.model import ProcessModel, model_from_dict

# Printed matrices of the practical example for one workpiece (Stryczek 2014).
PAPER_R_TF = np.array([[1, 1, 0, 0, -1, -1, -1], [0, 0, -1, 1, 0, 0, 0]])
PAPER_R_WF = np.array([[1, 1, 0, 1, 0, 0, 0], [0, 0, -1, 0, -1, -1, -1]])
PAPER_R_FD = np.eye(7)
PAPER_R_FD[2, 3] = -1


def test_guide_pins_blocks_equal_the_printed_matrices(guide_pins_model: ProcessModel) -> None:
    rm = relation_matrices(guide_pins_model)
    for p in range(4):
        f = slice(7 * p, 7 * p + 7)
        np.testing.assert_array_equal(rm.R_TF[:, f], PAPER_R_TF)
        np.testing.assert_array_equal(rm.R_WF[[p, p + 4], f], PAPER_R_WF)
        np.testing.assert_array_equal(rm.R_FD[f, f], PAPER_R_FD)
        others = np.delete(np.arange(8), [p, p + 4])
        assert not rm.R_WF[others, f].any()


def test_d4_moves_with_w1_w5_and_twice_t23(guide_pins_model: ProcessModel) -> None:
    rm = relation_matrices(guide_pins_model)
    column = rm.composite[:, rm.dimensions.index("P1D4")]
    expected = dict.fromkeys(rm.registers, 0.0) | {"W1": 1.0, "W5": 1.0, "T23": 2.0}
    assert dict(zip(rm.registers, column, strict=True)) == expected
    # a unit change of each moves D4 by its weight: +0.01 on W1, W5 and T23 → +0.04
    x = np.zeros(len(rm.registers))
    x[[rm.registers.index(r) for r in ("W1", "W5", "T23")]] = 0.01
    assert predict_dimensions(x, rm.composite)[rm.dimensions.index("P1D4")] == pytest.approx(0.04)


def test_features_by_eq3_including_the_machine_level() -> None:
    # The paper's first illustration: F1 = -M1 + W1 + T1, F2 = -M1 + W2 - T1, D2 = F1 - F2.
    doc = {
        "process": {"name": "illustration"},
        "machine": {"M1": {"wks": {"W1": -1, "W2": -1}}},
        "wks": {"W1": {}, "W2": {}},
        "tools": {"T1": {}},
        "features": {"F1": {"wks": {"W1": 1}, "tools": {"T1": 1}}, "F2": {"wks": {"W2": 1}, "tools": {"T1": -1}}},
        "dimensions": {
            "D1": {"features": {"F1": 1}, "nominal": 1, "lower": -1, "upper": 1},
            "D2": {"features": {"F1": 1, "F2": -1}, "nominal": 1, "lower": -1, "upper": 1},
        },
    }
    rm = relation_matrices(model_from_dict(doc))
    m, w, t = np.array([0.3]), np.array([0.01, 0.02]), np.array([0.005])
    f = predict_features(w, t, rm.R_WF, rm.R_TF, m=m, r_mw=rm.R_MW)
    assert f == pytest.approx([-0.3 + 0.01 + 0.005, -0.3 + 0.02 - 0.005])
    d = f @ rm.R_FD
    # D2 = F1 - F2 = W1 - W2 + 2 T1: the machine point cancels
    assert d[1] == pytest.approx(0.01 - 0.02 + 2 * 0.005)


def test_rank_and_null_space_of_the_paper_example(guide_pins_model: ProcessModel) -> None:
    rm = relation_matrices(guide_pins_model)
    comp = rm.composite
    assert np.linalg.matrix_rank(comp) == 9
    (direction,) = null_space_directions(comp)
    expected = np.array([-1.0] * 8 + [1.0] * 2)  # all tools +a with all WKS -a
    np.testing.assert_allclose(direction, expected)
    np.testing.assert_allclose(direction @ comp, 0.0, atol=1e-12)


def test_null_space_empty_when_full_rank() -> None:
    comp = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, -1.0]])
    assert null_space_directions(comp).shape == (0, 2)


def test_null_space_spans_and_is_readable() -> None:
    rng = np.random.default_rng(0)
    comp = rng.integers(-1, 2, size=(3, 6)).astype(float)
    comp = np.vstack([comp, comp[0] + comp[1], comp[2] - comp[0]])  # rank ≤ 3, two extra dependencies
    null = null_space_directions(comp)
    assert null.shape[0] == comp.shape[0] - np.linalg.matrix_rank(comp)
    np.testing.assert_allclose(null @ comp, 0.0, atol=1e-9)
    assert np.allclose(np.abs(null).max(axis=1), 1.0)


def test_matrices_are_kept_per_model_object_and_never_stale(guide_pins_model: ProcessModel) -> None:
    """The matrices are built once per model object (batch: once, not per report), are read-only,
    and a different model, even one equal in all but one weight, gets its own."""
    import dataclasses

    first = relation_matrices(guide_pins_model)
    assert relation_matrices(guide_pins_model) is first
    assert first.composite is first.composite
    for array in (first.R_WF, first.R_TF, first.R_FD, first.composite):
        with pytest.raises(ValueError):
            array[0, 0] = 5.0
    d0 = guide_pins_model.dimensions[0]
    feature = next(iter(d0.features))
    changed = dataclasses.replace(
        guide_pins_model,
        dimensions=(
            dataclasses.replace(d0, features={**d0.features, feature: 2.0 * d0.features[feature]}),
            *guide_pins_model.dimensions[1:],
        ),
    )
    other = relation_matrices(changed)
    assert other is not first
    np.testing.assert_array_equal(other.R_FD[:, 1:], first.R_FD[:, 1:])
    assert other.R_FD[[f.id for f in changed.features].index(feature), 0] == 2.0 * d0.features[feature]
    # More models than are kept (the last few): each still gets its own matrices, never another's, and the
    # first ones are let go -- built again when asked for, not held for ever.
    models = [dataclasses.replace(guide_pins_model, dimensions=guide_pins_model.dimensions[:k]) for k in range(1, 29)]
    kept = [relation_matrices(m) for m in models]
    for m in models:
        assert relation_matrices(m).R_FD.shape == (len(m.features), len(m.dimensions))
    assert relation_matrices(models[0]) is not kept[0]
