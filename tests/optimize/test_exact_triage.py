"""Triage and register costs of the exact optimiser, against brute force over whole small grids."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from setupfix.model import PartMeasurement
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.pipeline.cycles import load_parts

from .test_exact import random_problem
from .test_exact_robust import GUIDE_PINS


def grid_points(problem: CorrectionProblem) -> np.ndarray:
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    return np.array(list(itertools.product(*axes)), dtype=float) * problem.resolution


def brute_triage(problem: CorrectionProblem) -> tuple[int, float, float]:
    """Most dimensions in tolerance, then their error budget, then the least weighted norm."""
    x = grid_points(problem)
    margins = problem.margins(x)
    ok = margins >= -1e-12
    count = ok.sum(axis=1)
    best_count = count.max()
    budget = np.where(ok, margins, np.inf).min(axis=1)
    top = budget[count == best_count].max()
    chosen = (count == best_count) & (budget >= top - 1e-12)
    norm = np.sqrt(np.sum(problem.cost * x[chosen] ** 2, axis=1)).min()
    return int(best_count), float(top), float(norm)


@pytest.mark.parametrize("seed", range(8))
def test_triage_equals_brute_force(seed):
    problem = random_problem(seed, n=3, m=7, limit_steps=2, spread=0.3)
    result = get_optimizer("exact", objective="paper").solve(problem)
    count, budget, norm = brute_triage(problem)
    margins = problem.margins(result.x)
    kept = margins >= -1e-12
    if count == len(problem.dimension_ids):  # everything can be kept: no triage
        assert result.given_up == ()
        return
    assert result.status == "optimal"
    assert kept.sum() == count
    assert set(result.given_up) == {d for d, k in zip(problem.dimension_ids, kept, strict=True) if not k}
    assert margins[kept].min() == pytest.approx(budget, abs=1e-12)
    assert result.norm == pytest.approx(norm, abs=1e-12)
    assert "given up" in result.message and "NC program or the process" in result.message


def test_one_gross_error_does_not_push_good_dimensions_out(guide_pins_model):
    """Issue 13: P1 D1 at −0.25 mm on ±0.1 must not move P1 D2 (−0.029, in tolerance) out."""
    (part,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    dev = part.deviation.copy()
    ids = [d.id for d in guide_pins_model.dimensions]
    dev[0] = -0.25
    problem = CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, dev, part.sources))
    result = get_optimizer("exact", objective="paper").solve(problem)
    margins = problem.margins(result.x)
    assert result.given_up == (ids[0],)
    assert np.all(np.delete(margins, 0) >= 0)
    assert result.status == "optimal"


def test_a_costlier_register_moves_less_among_equally_good_corrections():
    """Two registers that move the dimensions alike: the cheap one takes the shift."""
    comp = np.array([[1.0, 1.0, -1.0], [1.0, 1.0, -1.0], [0.0, 1.0, 1.0]])
    base = dict(composite=comp, deviation=np.array([0.03, 0.03, -0.03]), lower=np.full(3, -0.05),
                upper=np.full(3, 0.05), lb=np.full(3, -0.05), ub=np.full(3, 0.05), resolution=0.001,
                register_ids=("G54", "H5", "H6"), dimension_ids=("D1", "D2", "D3"))
    plain = get_optimizer("exact", objective="paper").solve(CorrectionProblem(**base))
    paper = get_optimizer("exact", objective="paper")
    tool_dear = paper.solve(CorrectionProblem(**base, cost=np.array([1.0, 10.0, 1.0])))
    wks_dear = paper.solve(CorrectionProblem(**base, cost=np.array([10.0, 1.0, 1.0])))
    assert plain.margin_after == tool_dear.margin_after == wks_dear.margin_after
    assert abs(tool_dear.x[1]) < abs(plain.x[1]) and abs(tool_dear.x[0]) > abs(plain.x[0])
    assert abs(wks_dear.x[0]) < abs(plain.x[0])


@pytest.mark.parametrize("seed", range(6))
def test_weighted_least_norm_equals_brute_force(seed):
    problem = random_problem(200 + seed, n=4, m=6, limit_steps=4)
    cost = np.random.default_rng(seed).uniform(0.2, 5.0, problem.n_registers)
    weighted = CorrectionProblem(problem.composite, problem.deviation, problem.lower, problem.upper, problem.lb,
                                 problem.ub, problem.resolution, problem.register_ids, problem.dimension_ids,
                                 cost=cost)
    result = get_optimizer("exact", objective="paper").solve(weighted)
    x = grid_points(weighted)
    f1, _, _ = weighted.evaluate(x)
    best = f1.max()
    if best < 0:
        pytest.skip("out of reach: triage case")
    norm = np.sqrt(np.sum(cost * x[f1 >= best - 1e-12] ** 2, axis=1)).min()
    assert result.margin_after == pytest.approx(best, abs=1e-12)
    assert np.sqrt(np.sum(cost * result.x**2)) == pytest.approx(norm, abs=1e-12)


@pytest.mark.parametrize("cost", [np.array([1.0, 0.0, 1.0]), np.array([1.0, np.inf, 1.0]), np.ones(2)])
def test_register_cost_must_be_positive_and_finite(cost):
    from setupfix.errors import ParameterError

    problem = random_problem(0, n=3)
    with pytest.raises(ParameterError, match="register cost"):
        CorrectionProblem(problem.composite, problem.deviation, problem.lower, problem.upper, problem.lb,
                          problem.ub, problem.resolution, problem.register_ids, problem.dimension_ids, cost=cost)


def test_metaheuristics_give_nothing_up():
    problem = random_problem(5, limit_steps=1, spread=0.3)
    assert get_optimizer("pso", seed=1, n_solutions=200).solve(problem).given_up == ()


def test_no_dimension_in_reach_gives_the_least_correction():
    """One dimension out of reach of a ±1-step register (hypothesis found it): x = 0, given up, no crash."""
    problem = random_problem(1845, n=1, m=1, limit_steps=1)
    result = get_optimizer("exact", objective="paper").solve(problem)
    assert brute_triage(problem)[0] == 0
    assert result.status == "optimal"
    assert np.all(result.x == 0)
    assert result.given_up == problem.dimension_ids
