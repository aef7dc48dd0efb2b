"""Least norm at shop scale: each piece against brute force or the full solve, and the stopped-proof fallback."""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest

import setupfix.optimize._grid_least_norm as least_norm_stage
from setupfix.optimize import get_optimizer
from setupfix.optimize._grid import grid_margins, least_distance
from setupfix.optimize._least_norm import (
    box_least_norm,
    descend,
    lagrangian_box,
    least_distance_working_set,
    lower_bound_ratio,
)
from setupfix.optimize._listing import lagrangian_ball
from setupfix.optimize._lp_bound import margin_rows

from .test_exact_robust import shop_problem


def small_system(seed: int, n: int = 4, r: int = 10, steps: int = 4):
    """Integer rows G k ≤ b that the grid point 0 … may or may not meet; box ±steps."""
    rng = np.random.default_rng(seed)
    g_rows = rng.integers(-2, 3, size=(r, n)).astype(float)
    k0 = rng.integers(-steps, steps + 1, n).astype(float)  # a grid point that meets every row
    b = g_rows @ k0 + rng.integers(0, 3, r)
    kmin, kmax = np.full(n, -float(steps)), np.full(n, float(steps))
    cost = rng.choice([1.0, 2.0, 3.0], n)
    return g_rows, b, kmin, kmax, cost


def grid_points(lo, hi):
    return np.array(list(itertools.product(*[np.arange(a, c + 1) for a, c in zip(lo, hi, strict=True)])), dtype=float)


@pytest.mark.parametrize("seed", range(8))
def test_working_set_nnls_equals_the_full_least_distance(seed):
    g_rows, b, kmin, kmax, cost = small_system(seed, n=6, r=60)
    status, full = least_distance(g_rows, b, kmin, kmax, cost)
    ws_status, ws = least_distance_working_set(g_rows, b, kmin, kmax, cost, time.perf_counter() + 10, add=3)
    assert status == ws_status == "optimal"
    np.testing.assert_allclose(ws[0], full[0], atol=1e-7)
    assert np.all(g_rows @ ws[0] <= b + 1e-7)
    assert all(np.all(v >= 0) for v in ws[1:])


def test_working_set_nnls_proves_an_empty_system():
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    b = np.array([-1.0, -1.0, 5.0])  # k0 ≤ −1 and k0 ≥ 1
    status, out = least_distance_working_set(g_rows, b, np.full(2, -9.0), np.full(2, 9.0), np.ones(2),
                                             time.perf_counter() + 10, add=1)
    assert status == "infeasible" and out is None


@pytest.mark.parametrize("seed", range(8))
def test_lagrangian_box_holds_every_point_up_to_the_norm_and_bounds_the_least(seed):
    g_rows, b, kmin, kmax, cost = small_system(seed)
    _, (_k, lam, lam_lo, lam_hi) = least_distance(g_rows, b, kmin, kmax, cost)
    centre, q = lagrangian_ball(g_rows, b, kmin, kmax, cost, lam, lam_lo, lam_hi)
    pts = grid_points(kmin, kmax)
    feasible = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    f = np.sum(cost * feasible**2, axis=1)
    for f_best in (f.min(), np.median(f)):
        lo, hi, lower = lagrangian_box(centre, q, cost, kmin, kmax, f_best)
        inside = np.all((feasible >= lo) & (feasible <= hi), axis=1)
        assert np.all(inside[f <= f_best])
        assert lower <= f.min() + 1e-9
    assert lower_bound_ratio(f.min(), lower) >= 1.0


@pytest.mark.parametrize("seed", range(8))
def test_box_least_norm_equals_brute_force_over_the_box(seed):
    g_rows, b, kmin, _kmax, cost = small_system(seed)
    rng = np.random.default_rng(100 + seed)
    lo = kmin + rng.integers(0, 3, kmin.size)
    hi = np.maximum(lo + rng.integers(0, 4, kmin.size), lo)
    pts = grid_points(lo, hi)
    pts = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    res, k = box_least_norm(g_rows, b, lo, hi, cost, 10.0)
    if pts.size == 0:
        assert res.status == "infeasible" and k is None
        return
    assert res.status == "optimal"
    least = np.sum(cost * pts**2, axis=1).min()
    assert np.sum(cost * k**2) == pytest.approx(least)
    assert res.objective == pytest.approx(least) and res.dual_bound <= least + 1e-6
    assert np.all(g_rows @ k <= b + 1e-9) and np.all((k >= lo) & (k <= hi))


@pytest.mark.parametrize("seed", range(6))
def test_descend_keeps_every_row_and_ends_where_no_single_move_helps(seed):
    g_rows, b, kmin, kmax, cost = small_system(seed, steps=6)
    pts = grid_points(kmin, kmax)
    feasible = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    start = feasible[np.argmax(np.sum(cost * feasible**2, axis=1))]  # the largest feasible point
    k = descend(g_rows, b, start, cost, time.perf_counter() + 10)
    assert np.all(g_rows @ k <= b + 1e-9)
    assert np.sum(cost * k**2) <= np.sum(cost * start**2)
    for i in range(k.size):  # no feasible single-coordinate move lowers the norm
        for v in np.arange(kmin[i], kmax[i] + 1):
            moved = k.copy()
            moved[i] = v
            if np.all(g_rows @ moved <= b + 1e-9):
                assert cost[i] * v**2 >= cost[i] * k[i] ** 2


def test_a_stopped_least_norm_proof_returns_a_certified_near_least_correction(monkeypatch):
    """The limit hit in the least-norm stage: the stage is named, and ‖x‖ is within the certified ratio."""
    problem = shop_problem(100, 800, 1)  # 100 registers: the chord MILP in the Lagrangian box
    proven = get_optimizer("exact", objective="paper", time_limit=30.0).solve(problem)
    assert proven.status == "optimal"
    real = least_norm_stage.chord_proof

    def out_of_time(*args, **kwargs):
        kwargs["time_limit"] = 0.0  # the proof stops at once, as at the deadline
        return real(*args, **kwargs)

    monkeypatch.setattr(least_norm_stage, "chord_proof", out_of_time)
    result = get_optimizer("exact", objective="paper", time_limit=30.0).solve(problem)
    assert result.status == "time_limit"
    assert result.extra["stopped"] == {"stage": "least norm", "reason": "time limit"}
    assert "least-norm stage" in result.message and "certified" in result.message
    assert result.margin_after == pytest.approx(proven.margin_after, abs=1e-12)  # the grid optimum is kept
    ratio = result.extra["norm_ratio_max"]
    assert 1.0 <= ratio < 1.1
    assert proven.norm - 1e-12 <= result.norm <= ratio * proven.norm + 1e-12
    x_steps = result.x / problem.resolution
    assert grid_margins(*margin_rows(problem), x_steps[problem.free]) >= result.margin_after / \
        problem.resolution - 1e-6
