"""Every level, pin and saturation the leximin search claims holds on the whole level set (brute force)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import setupfix.optimize._leximin as lexmod
from setupfix.optimize._leximin_pins import Certificates, dim_all, pinned_rows, span_closure

from .test_leximin import brute_leximin, guide_pins_window, one_axis_problem, solved_steps

EPS = 5e-4  # half the input quantum [steps]


def checked_levels(monkeypatch) -> list[int]:
    """Wrap the search's level proofs: each claim is checked against every grid point of the box."""
    grid: dict[str, np.ndarray] = {}
    seen: list[int] = []
    original = lexmod._level

    def level(search, v, k, given, active_rows, path):
        out = original(search, v, k, given, active_rows, path)
        k_out, t, sat, pin, stop, _ = out
        if stop is not None:
            return out
        rows, model = search.session.rows, search.model
        if "k" not in grid:
            axes = [np.arange(lo, hi + 1) for lo, hi in zip(rows.kmin, rows.kmax, strict=True)]
            grid["k"] = np.array(list(itertools.product(*axes)), dtype=float)
        pts = grid["k"]
        m_rows = rows.g[None, :] - pts @ rows.g_rows.T
        m_dims = np.full((len(pts), model.n_dims), np.inf)
        for j, q in enumerate(model.row_dim):
            m_dims[:, q] = np.minimum(m_dims[:, q], m_rows[:, j])
        active, fixed = np.isnan(v), np.isfinite(v)
        base = np.all(m_dims[:, fixed] >= v[fixed] - 1e-9, axis=1)
        in_set = base & np.all(m_dims[:, active] >= t - 1e-9, axis=1)
        assert not np.any(base & np.all(m_dims[:, active] >= t + EPS, axis=1)), "a grid point is above the level"
        assert in_set[np.flatnonzero(np.all(pts == k_out, axis=1))[0]], "the level's point is not in its level set"
        values = (pts[in_set] @ rows.g_rows.T)
        assert np.all(np.ptp(values[:, pin], axis=0) < 1e-9), "a pinned row moves on the level set"
        assert np.all(m_rows[in_set][:, sat] <= t + EPS + 1e-9), "a saturated row rises on the level set"
        # the span closure of the pins is exact too
        closed = span_closure(rows.g_rows, rows.d, pin, model.key)
        assert np.all(np.ptp(values[:, closed], axis=0) < 1e-9), "a row in the span of pins moves"
        seen.append(int(pin.sum() + sat.sum()))
        return out

    monkeypatch.setattr(lexmod, "_level", level)
    return seen


@pytest.mark.parametrize(("kind", "seed"), [("window", 1), ("window", 2), ("window", 3), ("window", 5),
                                            ("axis", 5), ("axis", 37), ("axis", 3), ("axis", 11)])
def test_every_claim_of_the_levels_holds_on_the_level_set(kind, seed, monkeypatch):
    problem = guide_pins_window(seed) if kind == "window" else one_axis_problem(seed)
    best, norm, _ = brute_leximin(problem)
    if best[0] < 0:
        pytest.skip("triage")
    seen = checked_levels(monkeypatch)
    _, k, sorted_m = solved_steps(problem)
    assert seen and sum(seen) > 0  # the proofs did pin or saturate rows (the checks above ran on them)
    np.testing.assert_allclose(sorted_m, best, atol=1e-6)
    assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)


def test_a_rounding_error_with_a_tiny_weight_pins_nothing():
    """Weights of 1e-17 with a weighted sum of ~1e-16 (a rounding error): no room below d is claimed."""
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    rhs = np.array([0.0, 0.0, 3.0])
    y = np.array([0.5, 0.5, 1e-17])
    cert = Certificates(g_rows, np.array([-5.0, -5.0]), np.array([5.0, 5.0]), ((y, rhs, np.zeros(3), True),))
    _, pin = pinned_rows(cert, np.ones(3, bool), EPS, np.ones(3))
    # rows 0 and 1 add up to 0 (x0 ≤ 0 and −x0 ≤ 0: pinned); row 2's tiny weight proves nothing about it
    assert pin.tolist() == [True, True, False]


def test_span_closure_adds_exactly_the_rows_in_the_span():
    g_rows = np.array([[1.0, 1, 0], [0, 1, 1], [1, 2, 1], [1, 0, -1], [1, 0, 0], [-1, -2, -1]])
    key = g_rows @ np.array([3.0, 7.0, 11.0])
    closed = span_closure(g_rows, np.ones(6), np.array([True, True, False, False, False, False]), key)
    assert closed.tolist() == [True, True, True, True, False, True]
    assert dim_all(closed, np.array([0, 0, 1, 1, 2, 2]), 3).tolist() == [True, True, False]
