"""Least norm at shop scale: each piece against brute force or the full solve, and the stopped-proof fallback."""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

import setupfix.optimize.exact.least_norm.grid as least_norm_stage
from setupfix.optimize import CorrectionProblem, Stopped, get_optimizer
from setupfix.optimize.exact.grid import grid_margins, least_distance
from setupfix.optimize.exact.least_norm.listing import lagrangian_ball
from setupfix.optimize.exact.least_norm.shop import (
    box_least_norm,
    descend,
    lagrangian_box,
    least_distance_working_set,
    lower_bound_ratio,
    network_rows,
)
from setupfix.optimize.exact.lp_bound import margin_rows
from setupfix.optimize.exact.settings import ExactSettings
from setupfix.optimize.exact.work import now

from .test_exact_robust import shop_problem

Array = npt.NDArray[np.float64]


def small_system(seed: int, n: int = 4, r: int = 10, steps: int = 4) -> tuple[Array, Array, Array, Array, Array]:
    """Integer rows G k ≤ b that the grid point 0 … may or may not meet; box ±steps."""
    rng = np.random.default_rng(seed)
    g_rows = rng.integers(-2, 3, size=(r, n)).astype(float)
    k0 = rng.integers(-steps, steps + 1, n).astype(float)  # a grid point that meets every row
    b = g_rows @ k0 + rng.integers(0, 3, r)
    kmin, kmax = np.full(n, -float(steps)), np.full(n, float(steps))
    cost = rng.choice([1.0, 2.0, 3.0], n)
    return g_rows, b, kmin, kmax, cost


def grid_points(lo: Array, hi: Array) -> Array:
    return np.array(list(itertools.product(*[np.arange(a, c + 1) for a, c in zip(lo, hi, strict=True)])), dtype=float)


def solved_least_distance(
    g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array
) -> tuple[Array, Array, Array, Array]:
    """:func:`least_distance`'s point and multipliers (the system has a point)."""
    status, out = least_distance(g_rows, b, kmin, kmax, cost)
    assert out is not None, status
    return out


@pytest.mark.parametrize("seed", range(8))
def test_working_set_nnls_equals_the_full_least_distance(seed: int) -> None:
    g_rows, b, kmin, kmax, cost = small_system(seed, n=6, r=60)
    status, full = least_distance(g_rows, b, kmin, kmax, cost)
    ws_status, ws = least_distance_working_set(g_rows, b, kmin, kmax, cost, now() + 1e9, add=3)
    assert status == ws_status == "optimal" and ws is not None and full is not None
    np.testing.assert_allclose(ws[0], full[0], atol=1e-7)
    assert np.all(g_rows @ ws[0] <= b + 1e-7)
    assert all(np.all(v >= 0) for v in ws[1:])


def test_working_set_nnls_proves_an_empty_system() -> None:
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    b = np.array([-1.0, -1.0, 5.0])  # k0 ≤ −1 and k0 ≥ 1
    status, out = least_distance_working_set(
        g_rows, b, np.full(2, -9.0), np.full(2, 9.0), np.ones(2), now() + 1e9, add=1
    )
    assert status == "infeasible" and out is None


@pytest.mark.parametrize("seed", range(8))
def test_lagrangian_box_holds_every_point_up_to_the_norm_and_bounds_the_least(seed: int) -> None:
    g_rows, b, kmin, kmax, cost = small_system(seed)
    _k, lam, lam_lo, lam_hi = solved_least_distance(g_rows, b, kmin, kmax, cost)
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
def test_box_least_norm_equals_brute_force_over_the_box(seed: int) -> None:
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
    assert k is not None and np.sum(cost * k**2) == pytest.approx(least)
    assert res.objective == pytest.approx(least) and res.dual_bound <= least + 1e-6
    assert np.all(g_rows @ k <= b + 1e-9) and np.all((k >= lo) & (k <= hi))


@pytest.mark.parametrize("seed", range(6))
def test_descend_keeps_every_row_and_ends_where_no_single_move_helps(seed: int) -> None:
    g_rows, b, kmin, kmax, cost = small_system(seed, steps=6)
    pts = grid_points(kmin, kmax)
    feasible = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    start = feasible[np.argmax(np.sum(cost * feasible**2, axis=1))]  # the largest feasible point
    k = descend(g_rows, b, start, cost, now() + 1e9)
    assert np.all(g_rows @ k <= b + 1e-9)
    assert np.sum(cost * k**2) <= np.sum(cost * start**2)
    for i in range(k.size):  # no feasible single-coordinate move lowers the norm
        for v in np.arange(kmin[i], kmax[i] + 1):
            moved = k.copy()
            moved[i] = v
            if np.all(g_rows @ moved <= b + 1e-9):
                assert cost[i] * v**2 >= cost[i] * k[i] ** 2


@pytest.mark.slow
def test_a_stopped_least_norm_proof_returns_a_certified_near_least_correction(monkeypatch: pytest.MonkeyPatch) -> None:
    """The limit hit in the least-norm stage: the stage is named, and ‖x‖ is within the certified ratio."""
    problem = shop_problem(100, 800, 1)  # 100 registers: the chord MILP in the Lagrangian box
    proven = get_optimizer("exact", objective="paper", time_limit=30.0).solve(problem)
    assert proven.status == "optimal"
    real = least_norm_stage.chord_proof

    def out_of_time(*args: Any, **kwargs: Any) -> tuple[Array | None, bool, str, float]:
        kwargs["time_limit"] = 0.0  # the proof stops at once, as at the deadline
        return real(*args, **kwargs)

    monkeypatch.setattr(least_norm_stage, "chord_proof", out_of_time)
    result = get_optimizer("exact", objective="paper", time_limit=30.0).solve(problem)
    assert result.status == "time_limit"
    assert result.stopped == Stopped("least norm", "work limit")
    assert "least-norm stage" in result.message and "certified" in result.message
    assert result.margin_after == pytest.approx(proven.margin_after, abs=1e-12)  # the grid optimum is kept
    ratio = result.norm_ratio_max
    assert ratio is not None and 1.0 <= ratio < 1.1
    assert proven.norm - 1e-12 <= result.norm <= ratio * proven.norm + 1e-12
    x_steps = result.x / problem.resolution
    assert grid_margins(*margin_rows(problem), x_steps[problem.free]) >= result.margin_after / problem.resolution - 1e-6


# --- ties and network rows ---------------------------------------------------------------------


def tied_problem(seed: int, network: bool = False) -> CorrectionProblem:
    """Equal costs and registers in pairs with equal or opposite columns: the least norm is tied at many points.

    ``network``: every dimension is one WKS and one tool register (±1), so the rows are a network matrix
    (ties: a shift either register of a dimension can make).
    """
    rng = np.random.default_rng(seed)
    n, m, h = 6, (3 if network else 6), 0.01
    if network:
        comp = np.zeros((n, m))
        sign = rng.choice([-1.0, 1.0], m)  # a feature cut by a tool in a WKS: both with the feature's sign
        comp[rng.integers(0, 3, m), np.arange(m)] = sign
        comp[3 + rng.integers(0, 3, m), np.arange(m)] = sign  # either moves it: ties
    else:
        half = rng.integers(-1, 2, size=(n // 2, m)).astype(float)
        comp = np.repeat(half, 2, axis=0) * np.tile([1.0, -1.0], n // 2)[:, None] ** rng.integers(0, 2, (n, 1))
    width = rng.uniform(0.02, 0.05, m)
    return CorrectionProblem(
        composite=comp,
        deviation=np.round(rng.uniform(-0.04, 0.04, m), 3),
        lower=-width,
        upper=width,
        lb=np.full(n, -3 * h),
        ub=np.full(n, 3 * h),
        resolution=h,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def brute_lex(problem: CorrectionProblem) -> tuple[np.ndarray, int, bool]:
    """The lexicographically smallest grid point among those of the least norm at the best margin, how
    many points tie there, and whether that margin is ≥ 0 (else the solver triages)."""
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    k = np.array(list(itertools.product(*axes)), dtype=float)
    f1, _, _ = problem.evaluate(k * problem.resolution)
    reach = bool(f1.max() >= 0)
    k = k[f1 >= f1.max() - 1e-12]
    f = np.sum(problem.cost * k**2, axis=1)
    k = k[f == f.min()]
    return k[np.lexsort(k.T[::-1])[0]], k.shape[0], reach


#: Each way the least norm is proved (no NNLS rows: no listing in the grid-optimum stage; no registers for
#: the ellipsoid: no listing in the least-norm stage).
TIE_PATHS = {
    "listing": ExactSettings(),
    "QP + listing": ExactSettings(nnls_max_rows=0),
    "box MILPs": ExactSettings(nnls_max_rows=0, ellipsoid_max_registers=0),
    "lazy chord MILP": ExactSettings(nnls_max_rows=0, ellipsoid_max_registers=0, box_proof_max_registers=0),
}


@pytest.mark.slow
@pytest.mark.parametrize("path", list(TIE_PATHS))
@pytest.mark.parametrize("network", [False, True])
def test_ties_go_to_the_lexicographically_smallest_correction(path: str, network: bool) -> None:
    """Brute force over the whole grid, on problems built to tie, on every proof path (network LP on and off)."""
    tied = 0
    for seed in range(12):
        problem = tied_problem(seed, network)
        want, ties, reach = brute_lex(problem)
        if not reach:  # triage: another objective
            continue
        for lp in (True, False):
            settings = dataclasses.replace(TIE_PATHS[path], network_lp=lp)
            result = get_optimizer("exact", settings=settings, objective="paper").solve(problem)
            assert result.status == "optimal"
            np.testing.assert_array_equal(np.rint(result.x / problem.resolution), want)
        tied += ties > 1
    assert tied >= 4  # the problems do tie


def brute_tu(a: np.ndarray) -> bool:
    """Total unimodularity by every square submatrix's determinant (small a only)."""
    r, n = a.shape
    for size in range(1, min(r, n) + 1):
        for rows in itertools.combinations(range(r), size):
            for cols in itertools.combinations(range(n), size):
                if round(abs(np.linalg.det(a[np.ix_(rows, cols)]))) > 1:
                    return False
    return True


@pytest.mark.parametrize("seed", range(40))
def test_network_rows_is_exact_on_two_entry_rows(seed: int) -> None:
    """On rows of one or two ±1 entries the test agrees with total unimodularity (all minors); other rows
    (three entries, a 2) are never taken for network rows."""
    rng = np.random.default_rng(seed)
    r, n = 5, 4
    a = np.zeros((r, n))
    for j in range(r):
        cols = rng.choice(n, size=rng.integers(1, 3), replace=False)
        a[j, cols] = rng.choice([-1.0, 1.0], cols.size)
    assert network_rows(a, np.zeros(r)) == brute_tu(a)
    assert not network_rows(a, np.full(r, 0.5))  # a fractional right side
    b = a.copy()
    b[0, np.flatnonzero(b[0])[0]] = 2.0
    assert not network_rows(b, np.zeros(r))
    c = a.copy()
    c[0] = [1.0, -1.0, 1.0, 0.0]
    assert not network_rows(c, np.zeros(r))


@pytest.mark.parametrize("seed", range(8))
def test_network_rows_are_proved_by_one_chord_lp_equal_to_brute_force(seed: int) -> None:
    problem = tied_problem(seed, network=True)
    want, _, reach = brute_lex(problem)
    # no listing first (in the grid-optimum stage of small problems, in the least-norm stage up to 120
    # registers), which proves the least norm before the LP where it closes
    settings = ExactSettings(nnls_max_rows=0, ellipsoid_max_registers=0)
    result = get_optimizer("exact", settings=settings, objective="paper").solve(problem)
    assert result.status == "optimal"
    assert ("one LP over the chords" in result.path) == reach  # else triage
    if reach:
        np.testing.assert_array_equal(np.rint(result.x / problem.resolution), want)


def test_shop_rows_without_differences_take_the_network_lp_and_agree_with_the_listing() -> None:
    """60 × 400 with every dimension one WKS and one tool: the LP's answer equals the other paths'."""
    for seed in range(2):
        problem = network_shop_problem(60, 400, seed)
        lp = get_optimizer(
            "exact", objective="paper", time_limit=30.0, settings=ExactSettings(ellipsoid_max_registers=0)
        ).solve(problem)
        no_lp = ExactSettings(network_lp=False)
        other = get_optimizer("exact", objective="paper", time_limit=30.0, settings=no_lp).solve(problem)
        assert lp.status == other.status == "optimal"
        assert "one LP over the chords" in lp.path
        assert lp.norm == pytest.approx(other.norm, rel=1e-12)
        if "the tie is not broken" not in lp.path + other.path:
            np.testing.assert_array_equal(lp.x, other.x)  # the same tie pick


def network_shop_problem(n: int, m: int, seed: int) -> CorrectionProblem:
    """shop_problem without the 30 % differences of two features: network rows."""
    rng = np.random.default_rng(seed)
    n_wks = 2 * n // 3
    comp = np.zeros((n, m))
    sign = rng.choice([-1.0, 1.0], m)
    comp[rng.integers(0, n_wks, m), np.arange(m)] = sign
    comp[n_wks + rng.integers(0, n - n_wks, m), np.arange(m)] = sign
    lower = -np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    upper = np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    dev = np.round(0.03 * (1 - 2 * rng.random(n)) @ comp + 0.01 * (1 - 2 * rng.random(m)), 4)
    return CorrectionProblem(
        composite=comp,
        deviation=dev,
        lower=lower,
        upper=upper,
        lb=np.full(n, -0.1),
        ub=np.full(n, 0.1),
        resolution=0.001,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )
