"""Exact optimiser against brute force over whole small grids, and its guarantees."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from setupfix.correction.synthetic import simulate_deviations
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import CorrectionProblem, get_optimizer


def random_problem(
    seed: int, n: int = 3, m: int = 6, limit_steps: int = 5, fixed: tuple[int, ...] = (), spread: float = 0.06
) -> CorrectionProblem:
    rng = np.random.default_rng(seed)
    comp = rng.integers(-1, 2, size=(n, m)).astype(float)
    comp[0, 0] = 2.0  # a weight-2 relation like D4 ← 2·T23
    h = 0.01
    lb = np.full(n, -limit_steps * h)
    ub = np.full(n, limit_steps * h)
    lb[list(fixed)] = ub[list(fixed)] = 0.0
    width = rng.uniform(0.03, 0.1, m)
    return CorrectionProblem(
        composite=comp,
        deviation=np.round(rng.uniform(-spread, spread, m), 4),
        lower=-width,
        upper=width * rng.uniform(0.5, 1.5, m),
        lb=lb,
        ub=ub,
        resolution=h,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def brute_force(problem: CorrectionProblem) -> tuple[float, float]:
    """Best f1 over the whole grid and the least norm among the points reaching it."""
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    k = np.array(list(itertools.product(*axes)), dtype=float)
    f1, f2, _ = problem.evaluate(k * problem.resolution)
    best = f1.max()
    return float(best), float(f2[f1 >= best - 1e-12].min())


@pytest.mark.parametrize("seed", range(12))
def test_grid_optimum_and_least_norm_equal_brute_force(seed: int) -> None:
    problem = random_problem(seed)
    result = get_optimizer("exact", objective="paper").solve(problem)
    best, norm = brute_force(problem)
    assert result.status == "optimal"
    if best < 0:  # out of reach: triage (issue 13), checked against brute force in test_exact_triage
        assert result.given_up
        return
    assert result.margin_after == pytest.approx(best, abs=1e-12)
    assert result.norm == pytest.approx(norm, abs=1e-12)
    assert result.bound is not None and result.bound >= result.margin_after - 1e-12
    np.testing.assert_allclose(result.x / problem.resolution, np.rint(result.x / problem.resolution), atol=1e-9)


def test_fixed_registers_never_move_and_limits_hold() -> None:
    problem = random_problem(3, n=4, m=7, limit_steps=3, fixed=(1,))
    result = get_optimizer("exact", objective="paper").solve(problem)
    assert result.x[1] == 0.0
    assert np.all(result.x <= problem.ub + 1e-12) and np.all(result.x >= problem.lb - 1e-12)
    best = brute_force(problem)[0]
    if best < 0:  # out of reach: triage, the fixed register still fixed
        assert result.given_up
    else:
        assert result.margin_after == pytest.approx(best, abs=1e-12)


def test_out_of_reach_returns_least_bad_correction() -> None:
    problem = random_problem(5, limit_steps=1, spread=0.3)
    result = get_optimizer("exact", objective="paper").solve(problem)
    best, _ = brute_force(problem)
    assert best < 0 and problem.evaluate(result.x)[0] < 0 and not result.in_tolerance
    # triage (issue 13): the dimensions out of reach are given up, the others kept in tolerance;
    # δ is that of the kept dimensions (issue 22)
    assert result.given_up and "given up" in result.message
    kept = ~np.isin(problem.dimension_ids, result.given_up)
    assert np.all(problem.margins(result.x)[kept] >= 0)
    assert result.margin_after == pytest.approx(problem.margins(result.x)[kept].min(), abs=1e-12)


def test_binding_dimensions_prove_the_bound() -> None:
    problem = random_problem(7)
    result = get_optimizer("exact", objective="paper").solve(problem)
    assert result.binding
    # Relaxing every non-binding limit cannot raise the LP bound: the binding set alone explains it.
    keep = np.isin(problem.dimension_ids, result.binding)
    relaxed = CorrectionProblem(
        problem.composite[:, keep],
        problem.deviation[keep],
        problem.lower[keep],
        problem.upper[keep],
        problem.lb,
        problem.ub,
        problem.resolution,
        problem.register_ids,
        tuple(np.array(problem.dimension_ids)[keep]),
    )
    assert get_optimizer("exact", objective="paper").solve(relaxed).bound == pytest.approx(result.bound, abs=1e-9)


def test_time_limit_falls_back_and_says_so() -> None:
    # large enough that HiGHS cannot finish in presolve before it looks at the clock
    problem = random_problem(2, n=10, m=40, limit_steps=50)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # notes are data: nothing may go through warnings
        result = get_optimizer("exact", objective="paper", time_limit=1e-9).solve(problem)
    assert result.status == "time_limit"
    assert any(n.kind == "solver" and "time limit" in n.message for n in result.notes)
    assert result.stopped is not None and result.stopped.reason == "time limit"
    assert result.bound is None or result.margin_after <= result.bound + 1e-12  # None: stopped in the LP
    assert "not proved" in result.message


def test_paper_size_problem_against_lp_bound_and_null_space(guide_pins_model: ProcessModel) -> None:
    devs, _setup = simulate_deviations(guide_pins_model, 3, seed=11)
    for dev in devs:
        part = PartMeasurement("c", "r", None, dev, ("",) * dev.size)
        problem = CorrectionProblem.from_part(guide_pins_model, part)
        result = get_optimizer("exact", objective="paper").solve(problem)
        assert result.status == "optimal"
        assert result.bound is not None and result.margin_before <= result.margin_after <= result.bound + 1e-12
        # least norm: moving along the null space (tools +a, WKS -a) by one step cannot shorten x
        direction = np.r_[-np.ones(8), np.ones(2)] * problem.resolution
        for step in (-1, 1):
            moved = result.x + step * direction
            if np.all(moved >= problem.lb) and np.all(moved <= problem.ub):
                assert np.linalg.norm(moved) >= result.norm - 1e-12


def test_continuous_mode_is_the_lp_optimum() -> None:
    problem = random_problem(4)
    cont = get_optimizer("exact", objective="paper", grid=False).solve(problem)
    assert cont.margin_after == pytest.approx(cont.bound, abs=1e-9)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 6), m=st.integers(1, 10), steps=st.integers(1, 20))
def test_no_grid_point_beats_the_exact_optimum(seed: int, n: int, m: int, steps: int) -> None:
    problem = random_problem(seed, n=n, m=max(m, 1), limit_steps=steps)
    result = get_optimizer("exact", objective="paper").solve(problem)
    rng = np.random.default_rng(seed)
    k = rng.integers(problem.kmin, problem.kmax + 1, size=(2000, n))
    f1, _, _ = problem.evaluate((k * problem.resolution).astype(float))
    if result.given_up and result.status == "time_limit":  # a triage whose leximin levels outran the limit
        assert result.stopped is not None and result.stopped.stage == "triage"  # says so (issue 22: never "optimal")
    else:
        assert result.status == "optimal"
    if result.given_up:  # triage: the kept dimensions are in tolerance, the others given up
        kept = ~np.isin(problem.dimension_ids, result.given_up)
        assert np.all(problem.margins(result.x)[kept] >= -1e-12) and f1.max() < 0
        return
    assert f1.max() <= result.margin_after + 1e-12
    assert result.bound is not None and result.margin_after <= result.bound + 1e-12
    assert np.all(np.abs(result.x) <= problem.ub + 1e-12)
