"""The pruned listings of the exact optimiser's proofs against brute force, and the cycles they serve."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.inputs.cycles import load_parts
from setupfix.model import load_model
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.optimize.exact.least_norm.listing import ellipsoid_search, enumerate_ball, lagrangian_ball
from setupfix.optimize.exact.settings import ExactSettings

from .test_exact import brute_force, random_problem
from .test_exact_robust import GUIDE_PINS
from .test_least_norm import grid_points, small_system, solved_least_distance

Array = npt.NDArray[np.float64]


def brute_ball(
    pts: Array, centre: Array, cost: Array, radius2: float, g_rows: Array, b: Array, fmax: float
) -> set[tuple[float, ...]]:
    keep = np.sum(cost * (pts - centre) ** 2, axis=1) <= radius2
    keep &= np.all(pts @ g_rows.T <= b + 1e-9, axis=1)
    keep &= np.sum(cost * pts**2, axis=1) <= fmax
    return {tuple(p) for p in pts[keep]}


@pytest.mark.parametrize("seed", range(10))
def test_enumerate_ball_lists_exactly_the_points_of_brute_force(seed: int) -> None:
    """Radius, rows and norm pruning (with the QP's multipliers and with arbitrary ones) drop nothing."""
    g_rows, b, kmin, kmax, cost = small_system(seed, n=5, r=10, steps=4)  # 9⁵ points: no whole-box shortcut
    _k, lam, lam_lo, lam_hi = solved_least_distance(g_rows, b, kmin, kmax, cost)
    centre, q = lagrangian_ball(g_rows, b, kmin, kmax, cost, lam, lam_lo, lam_hi)
    pts = grid_points(kmin, kmax)
    feasible = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    f = np.sum(cost * feasible**2, axis=1)
    rng = np.random.default_rng(seed)
    for fmax in (float(f.min()), float(np.median(f))):
        radius2 = fmax - q + 1e-9
        expected = brute_ball(pts, centre, cost, radius2, g_rows, b, fmax)
        assert expected  # the points of least norm at least
        scaled = (rng.uniform(0, 2, lam.size), rng.uniform(0, 2, lam_lo.size), rng.uniform(0, 2, lam_hi.size))
        choices: tuple[tuple[Array, Array, Array] | None, ...] = (None, (lam, lam_lo, lam_hi), scaled)
        for multipliers in choices:
            listed = enumerate_ball(
                centre,
                cost,
                radius2,
                kmin,
                kmax,
                10**6,
                g_rows,
                b,
                fmax=fmax,
                work_limit=10**9,
                multipliers=multipliers,
            )
            assert listed is not None and {tuple(p) for p in listed} == expected
    # an arbitrary centre and radius, rows only
    centre = rng.uniform(-3, 3, kmin.size)
    listed = enumerate_ball(centre, cost, 12.0, kmin, kmax, 10**6, g_rows, b, work_limit=10**9)
    assert listed is not None
    assert {tuple(p) for p in listed} == brute_ball(pts, centre, cost, 12.0, g_rows, b, np.inf)


@pytest.mark.parametrize("seed", range(10))
def test_ellipsoid_search_finds_the_least_norm_of_brute_force(seed: int) -> None:
    """Growing ellipsoids from no known point: the least Σ c k² (ties: the smallest k), proved."""
    g_rows, b, kmin, kmax, cost = small_system(seed, n=5, r=10, steps=4)
    _k, lam, lam_lo, lam_hi = solved_least_distance(g_rows, b, kmin, kmax, cost)
    centre, q = lagrangian_ball(g_rows, b, kmin, kmax, cost, lam, lam_lo, lam_hi)
    best, proved, _ = ellipsoid_search(
        g_rows,
        b,
        0.0,
        centre,
        q,
        cost,
        kmin,
        kmax,
        np.inf,
        10**6,
        b,
        work_limit=10**9,
        multipliers=(lam, lam_lo, lam_hi),
    )
    pts = grid_points(kmin, kmax)
    feasible = pts[np.all(pts @ g_rows.T <= b + 1e-9, axis=1)]
    f = np.sum(cost * feasible**2, axis=1)
    least = feasible[f == f.min()]
    assert proved and best is not None
    np.testing.assert_array_equal(best, least[np.lexsort(least.T[::-1])[0]])


def test_a_level_with_no_grid_point_is_proved_by_listing_the_whole_box() -> None:
    problem = random_problem(101, n=4, m=8, limit_steps=6)
    result = get_optimizer("exact", objective="paper").solve(problem)
    assert "the whole box listed" in result.path and "MILP" not in result.path
    best, norm = brute_force(problem)
    assert result.status == "optimal"
    assert result.margin_after == pytest.approx(best, abs=1e-12)
    assert result.norm == pytest.approx(norm, abs=1e-12)


@pytest.mark.parametrize("cycle", range(1, 6))
def test_guide_pins_cycles_equal_the_milp_proofs(cycle: int) -> None:
    """The bundled cycles (28 dimensions × 10 registers, a box of 201¹⁰ grid points: no brute force):
    the listings' answer equals the MILP proofs' answer with a long limit; cycle 4 needs no MILP."""
    model = load_model(GUIDE_PINS / "model.toml")
    (part,) = load_parts(model, GUIDE_PINS / f"cycle_{cycle:02d}.csv")
    problem = CorrectionProblem.from_part(model, part)
    fast = get_optimizer("exact", objective="paper").solve(problem)
    no_listing = ExactSettings(enumeration_limit=0, search_limit=0)
    slow = get_optimizer("exact", objective="paper", time_limit=60.0, settings=no_listing).solve(problem)
    assert fast.status == slow.status == "optimal"
    assert fast.margin_after == pytest.approx(slow.margin_after, abs=1e-12)
    assert fast.norm == pytest.approx(slow.norm, abs=1e-12)
    if cycle == 4:
        assert "MILP" not in fast.path and "MILP" in slow.path
