"""Objective functions f1, f2, f (eqs. 5–10) on hand-computed cases."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.correction.objective import correction_norm, error_budget, fitness, margins


def test_margin_is_distance_to_nearer_limit() -> None:
    dev = np.array([0.03, -0.08, 0.12, 0.0])
    lo = np.array([-0.1, -0.1, -0.1, -0.02])
    up = np.array([0.1, 0.1, 0.1, 0.05])
    assert margins(dev, lo, up) == pytest.approx([0.07, 0.02, -0.02, 0.02])
    assert error_budget(dev, lo, up) == pytest.approx(-0.02)


def test_symmetric_tolerance_equals_eqs_5_to_8() -> None:
    # eqs. 5–6 with eps_q the deviation and T_q the tolerance width: δ = min_q (T_q/2 − |ε_q|)
    rng = np.random.default_rng(1)
    eps = rng.uniform(-0.1, 0.1, 20)
    tol = rng.uniform(0.05, 0.3, 20)
    assert error_budget(eps, -tol / 2, tol / 2) == pytest.approx(np.min(tol / 2 - np.abs(eps)))


def test_one_sided_tolerance_and_absent_dimension() -> None:
    dev = np.array([0.01, np.nan, 0.02])
    assert error_budget(dev, np.array([-np.inf, -1, -0.1]), np.array([0.05, 1, 0.1])) == pytest.approx(0.04)


def test_population_axis_and_f() -> None:
    dev = np.array([[0.0, 0.05], [0.02, -0.01]])
    f1 = error_budget(dev, np.array([-0.1, -0.1]), np.array([0.1, 0.1]))
    assert f1 == pytest.approx([0.05, 0.08])
    x = np.array([[0.003, 0.004], [0.0, 0.0]])
    f2 = correction_norm(x)
    assert f2 == pytest.approx([0.005, 0.0])
    assert fitness(f1, f2) == pytest.approx([10 * 0.05 - 0.005, 0.8])
