"""Checks every registered optimiser passes, driven by the registry (exact and CRIPSO included).

Determinism per seed, the solution budget counted, declared and enforced parameter
ranges, the x = 0 guard, and results on the register grid within the limits.  A new
optimiser in ``OPTIMIZERS`` is covered without a line here; budgets are small.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from setupfix.core.errors import ParameterError
from setupfix.core.params import Constraint, accepts
from setupfix.optimize import (
    NO_BETTER_THAN_NONE,
    OPTIMIZERS,
    CorrectionProblem,
    Metaheuristic,
    Optimizer,
    get_optimizer,
    make_result,
)

from .test_metaheuristics_common import RecordingProblem, small_problem

NAMES = sorted(OPTIMIZERS)
#: Small budgets: every check here runs in well under a second per optimiser.
FAST = {
    "cs": {"n_nests": 10},
    "pso": {"n_particles": 10},
    "ga": {"population": 10},
    "coa": {"max_cuckoos": 10, "n_iterations": 20},
    "cripso": {"n_polyps": 10},
}


def make(name: str, seed: int = 0, budget: int = 300, **extra: Any) -> Optimizer:
    params = dict(FAST.get(name, {}), **extra)
    if issubclass(type(get_optimizer(name)), Metaheuristic):
        params["n_solutions"] = budget
    return get_optimizer(name, seed=seed, **params)


def centred_problem() -> CorrectionProblem:
    """Every dimension on nominal: no correction (x = 0) is the unique best error budget."""
    rng = np.random.default_rng(7)
    comp = rng.integers(-1, 2, size=(4, 9)).astype(float)
    comp[:, :4] += np.eye(4)
    return CorrectionProblem(
        composite=comp,
        deviation=np.zeros(9),
        lower=np.full(9, -0.1),
        upper=np.full(9, 0.1),
        lb=np.full(4, -0.1),
        ub=np.full(4, 0.1),
        resolution=0.001,
        register_ids=("W1", "W2", "T1", "T2"),
        dimension_ids=tuple(f"D{i}" for i in range(9)),
    )


@pytest.mark.parametrize("name", NAMES)
def test_same_seed_same_result(name: str) -> None:
    problem = small_problem(4)
    a, b = make(name, seed=3).solve(problem), make(name, seed=3).solve(problem)
    assert np.array_equal(a.x, b.x) and a.margin_after == b.margin_after and a.evaluations == b.evaluations
    if a.history is not None:
        assert b.history is not None and np.array_equal(a.history, b.history)


@pytest.mark.parametrize("name", NAMES)
def test_budget_counted_and_result_on_the_grid_within_limits(name: str) -> None:
    problem = small_problem(5, RecordingProblem)
    opt = make(name, budget=257)
    result = opt.solve(problem)
    if isinstance(opt, Metaheuristic):
        assert 1 <= result.evaluations <= 257
        assert result.history is not None and result.history[-1, 0] == result.evaluations
        logged = sum(len(r) for r in problem.log)  # every row the search evaluated, make_result's too
        assert logged >= result.evaluations + 1
        if name not in ("pso", "cripso"):  # PSO (speculative rows) and CRIPSO (its own loop) evaluate more
            assert logged <= result.evaluations + 2
    for x in [*problem.log, result.x[None, :]]:
        k = x / problem.resolution
        assert np.allclose(k, np.rint(k), atol=1e-9), "off the register grid"
        assert np.all(x >= problem.lb) and np.all(x <= problem.ub), "outside the register limits"
        assert np.all(x[:, 4] == 0.0), "a fixed register moved"
    f1, f2, _ = problem.evaluate(result.x)
    assert result.margin_after == pytest.approx(float(f1), abs=1e-12) and result.norm == pytest.approx(float(f2))


def _bad_value(constraints: list[Constraint]) -> object:
    """A value every constraint of a parameter refuses."""
    for value in (-1, -(10**9), 10**12, 0.5, 2.5, math.nan, "no such value", None):
        if not any(accepts(c, value) for c in constraints):
            return value
    raise AssertionError(f"no value outside {constraints}")


def _declared(name: str) -> tuple[Optimizer, dict[str, list[Constraint]]]:
    opt = get_optimizer(name)
    return opt, opt._parameter_constraints


@pytest.mark.parametrize("name", NAMES)
def test_every_parameter_is_declared(name: str) -> None:
    opt, declared = _declared(name)
    assert set(opt.get_params()) <= set(declared)


@pytest.mark.parametrize("name", NAMES)
def test_every_declared_parameter_refuses_a_value_out_of_range(name: str) -> None:
    opt, declared = _declared(name)
    for param in opt.get_params():
        if param not in declared:
            continue
        bad = _bad_value(declared[param])
        with pytest.raises(ParameterError, match=f"{param} must be"):
            get_optimizer(name, **{param: bad})


def test_the_issue_cases_and_unknown_names() -> None:
    for name, params in [
        ("pso", {"n_particles": -5}),
        ("coa", {"initial_cuckoos": 0}),
        ("ga", {"population": 0}),
        ("cs", {"pa": 7}),
        ("pso", {"n_solutions": 10**9}),
        ("cripso", {"n_polyps": 1}),
    ]:
        with pytest.raises(ParameterError, match=next(iter(params))):
            get_optimizer(name, **params)
    with pytest.raises(ParameterError, match=r"must be one of .*cripso.*got 'psoo'"):
        get_optimizer("psoo")
    with pytest.raises(ParameterError, match="unknown parameter 'particles'"):
        get_optimizer("pso", particles=5)


@pytest.mark.parametrize("name", NAMES)
def test_never_worse_than_no_correction(name: str) -> None:
    problem = centred_problem()
    result = make(name, budget=12).solve(problem)  # far too small a budget to find x = 0 by search
    assert result.margin_after >= problem.margin_before
    if result.status == NO_BETTER_THAN_NONE:
        assert not result.x.any() and "better than none" in result.message


def test_guard_returns_zero_and_says_so() -> None:
    problem = centred_problem()
    x = np.array([0.05, 0.0, -0.02, 0.0])
    guarded = make_result(problem, x, optimizer="pso", evaluations=1, seconds=0.0, status="budget")
    assert guarded.status == NO_BETTER_THAN_NONE and not guarded.x.any()
    assert [n.kind for n in guarded.notes] == ["solver"] and "better than none" in guarded.notes[0].message
    assert guarded.margin_after == problem.margin_before == pytest.approx(0.1)
    kept = make_result(problem, x, optimizer="exact", evaluations=1, seconds=0.0, status="optimal", guard=False)
    assert kept.status == "optimal" and np.array_equal(kept.x, x)
