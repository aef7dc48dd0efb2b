"""setupfix.correction.explain: leave-one-out residuals against explicit refits, and the one-register explanation."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.correction.explain import fit_registers, leave_one_out, one_register, targets


def test_leave_one_out_equals_refitting_without_each_dimension() -> None:
    rng = np.random.default_rng(3)
    c = rng.choice([-1.0, 0.0, 1.0], size=(4, 12))
    r = rng.normal(0, 0.05, 12)
    loo = leave_one_out(c, r)
    for q in range(12):
        use = np.ones(12, bool)
        use[q] = False
        x = fit_registers(c, r, use)
        assert loo[q] == pytest.approx(r[q] + c[:, q] @ x, abs=1e-9)


def test_one_register_names_the_register_that_alone_explains_a_shift() -> None:
    """A WKS entered 0.35 wrong: least squares spreads it over the WKS and the tool that moves the same
    dimensions; the one-register fit finds the WKS and the whole amount, with nothing left over."""
    c = np.array(
        [
            [1.0, 1.0, 1.0, 0.0, 0.0],  # W: the station's three dimensions
            [1.0, 1.0, 1.0, 1.0, 1.0],  # T: those and two of another station
            [0.0, 0.0, 0.0, 1.0, 1.0],
        ]
    )  # W': the other station
    r = np.array([0.35, 0.35, 0.35, 0.0, 0.0])
    spread = fit_registers(c, r)
    assert np.count_nonzero(np.abs(spread) > 1e-3) > 1  # the fit's minimum norm is not one register
    j, change, after = one_register(c, r)
    assert j == 0 and change == pytest.approx(-0.35)
    assert np.allclose(after, 0.0)
    # brute force: no other single register leaves a smaller sum of squares
    for k in range(3):
        a = -(c[k] @ r) / (c[k] @ c[k])
        assert np.sum((r + c[k] * a) ** 2) >= np.sum(after**2) - 1e-15


def test_one_register_with_nothing_to_move_and_targets_of_one_sided_limits() -> None:
    j, change, after = one_register(np.zeros((2, 3)), np.ones(3))
    assert (j, change) == (-1, 0.0) and np.array_equal(after, np.ones(3))
    assert np.array_equal(
        targets(np.array([-0.1, -np.inf, 0.0]), np.array([0.1, 0.2, np.inf])), np.array([0.0, 0.0, 0.0])
    )
