"""Every HiGHS answer is checked against its model; runs end on work limits, and the wall-clock guard holds."""

from __future__ import annotations

import itertools
import time
from dataclasses import replace

import numpy as np
import pytest

from setupfix.optimize.exact import work
from setupfix.optimize.exact.highs import INF, LinearModel, Solve


def knapsack() -> tuple[LinearModel, np.ndarray, float]:
    """max value within a weight budget (as min −value), 8 binaries; its optimum by brute force."""
    rng = np.random.default_rng(3)
    value, weight = rng.integers(1, 30, 8).astype(float), rng.integers(1, 20, 8).astype(float)
    cap = float(np.floor(weight.sum() / 2))
    model = LinearModel(
        -value, weight[None, :], np.array([-np.inf]), np.array([cap]), np.zeros(8), np.ones(8), integer=np.ones(8, bool)
    )
    points = np.array(list(itertools.product((0.0, 1.0), repeat=8)))
    best = float(np.min(np.where(points @ weight <= cap, -(points @ value), np.inf)))
    return model, np.zeros(8), best


def test_a_true_answer_passes_the_check() -> None:
    model, _, best = knapsack()
    res = model.solve(1e6)
    assert res.status == "optimal" and res.objective == pytest.approx(best)
    assert model.check(res.x, res.objective, res.dual_bound, res.status) == ""


def test_the_check_names_each_contradiction() -> None:
    model, start, best = knapsack()
    res = model.solve(1e6)
    assert res.x is not None
    # the start handed back as "optimal" with the optimum's value (the HiGHS 1.16 mis-answer)
    assert "objective" in model.check(start, best, best, "optimal")
    # the start with its own value, but a dual bound below it: not optimal at a zero gap
    assert "dual bound" in model.check(start, 0.0, best, "optimal")
    assert "row" in model.check(np.ones(8), model.value(np.ones(8)), best, "optimal")
    assert "fractional" in model.check(
        np.r_[0.5, np.zeros(7)], model.value(np.r_[0.5, np.zeros(7)]), model.value(np.r_[0.5, np.zeros(7)]), "optimal"
    )
    assert "bounds" in model.check(
        np.r_[-1.0, np.zeros(7)],
        model.value(np.r_[-1.0, np.zeros(7)]),
        model.value(np.r_[-1.0, np.zeros(7)]),
        "optimal",
    )


def test_a_wrong_optimal_answer_is_solved_again_without_the_start(monkeypatch: pytest.MonkeyPatch) -> None:
    """HiGHS's answer is replaced by the start labelled optimal on the first run (as 1.16 did on 10
    of 2,239 triage MILPs); the checked solve re-runs without the start and returns the optimum."""
    model, start, best = knapsack()
    real_run = LinearModel._run
    calls: list[bool] = []

    def first_run_lies(self: LinearModel, time_limit: float, start_: np.ndarray | None) -> Solve:
        res = real_run(self, time_limit, start_)
        calls.append(start_ is not None)
        if start_ is not None:
            return replace(res, x=np.asarray(start_, dtype=float).copy())
        return res

    monkeypatch.setattr(LinearModel, "_run", first_run_lies)
    res = model.solve(1e6, start)
    assert calls == [True, False]
    assert res.status == "optimal" and res.objective == pytest.approx(best)
    assert res.x is not None and model.value(res.x) == pytest.approx(best)


def test_an_answer_that_stays_wrong_is_an_error_never_optimal(monkeypatch: pytest.MonkeyPatch) -> None:
    model, start, best = knapsack()
    real_run = LinearModel._run

    def always_lies(self: LinearModel, time_limit: float, start_: np.ndarray | None) -> Solve:
        res = real_run(self, time_limit, start_)
        return replace(res, x=start.copy())

    monkeypatch.setattr(LinearModel, "_run", always_lies)
    res = model.solve(1e6, start)
    assert res.status == "error" and "fails its model" in res.detail
    # the point is feasible (all zero), so it is kept as a point, with its own objective
    assert res.x is not None and res.objective == pytest.approx(0.0) and res.objective > best


def test_lp_and_qp_answers_pass_the_check() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(6, 4))
    lp = LinearModel(
        rng.normal(size=4), a, np.full(6, -np.inf), np.abs(rng.normal(size=6)) + 1, np.full(4, -3.0), np.full(4, 3.0)
    )
    res = lp.solve(5.0)
    assert res.status == "optimal" and res.row_dual is not None
    qp = LinearModel(np.zeros(4), a, np.full(6, -np.inf), -np.ones(6), np.full(4, -9.0), np.full(4, 9.0))
    qp.set_hessian_diagonal(np.full(4, 2.0))
    res = qp.solve(5.0)
    assert res.status in ("optimal", "infeasible")
    if res.x is not None:
        assert res.objective == pytest.approx(float(np.sum(res.x**2)), rel=1e-6, abs=1e-9)


def market_split(m: int = 5, n: int = 40, limit_slack: float = 0.0) -> LinearModel:
    """Cornuéjols–Dawande market split: equality rows of random weights, binaries — hard for branch and bound."""
    rng = np.random.default_rng(0)
    a = rng.integers(0, 100, (m, n)).astype(float)
    b = np.floor(a.sum(axis=1) / 2)
    return LinearModel(np.zeros(n), a, b, b, np.zeros(n), np.ones(n), integer=np.ones(n, bool), limit_slack=limit_slack)


def test_the_wall_clock_guard_stops_a_mip_whose_work_limit_is_far(monkeypatch: pytest.MonkeyPatch) -> None:
    """A hard MIP with a huge work allowance: only the guard (its wall clock run 100× fast) stops it,
    through the interrupt callbacks, and the meter says the guard fired.  (How soon, in seconds, is
    ``bench/wall_guard.py``'s.)"""
    model = market_split()
    real = time.perf_counter
    began = real()
    monkeypatch.setattr(work, "wall_clock", lambda: began + 100.0 * (real() - began))
    token = work.CURRENT.set(work.Meter(guard=began + 5.0))  # 0.05 s of real time
    try:
        res = model.solve(1e12)
        meter = work.current()
    finally:
        work.CURRENT.reset(token)
    assert res.status == "time_limit" and "nterrupt" in res.detail
    assert meter.fired


def test_a_work_allowance_stops_a_mip_the_same_way_every_time() -> None:
    """The node limit, not the clock, ends a run: two runs with one allowance do the same work and
    stop at the same point (with and without a start)."""
    outcomes = []
    for start in (None, np.zeros(40), None, np.zeros(40)):
        token = work.CURRENT.set(work.Meter())
        try:
            res = market_split().solve(20_000.0, start)
        finally:
            work.CURRENT.reset(token)
        assert res.status in ("time_limit", "infeasible", "optimal")
        outcomes.append((res.status, res.detail, res.seconds, None if res.x is None else res.x.tobytes()))
    assert outcomes[0][0] == "time_limit" and "limit" in outcomes[0][1]  # the node limit, not an interrupt
    assert outcomes[0] == outcomes[2] and outcomes[1] == outcomes[3]
    assert 0 < outcomes[0][2] <= 20_000.0 + work.Meter().node_work * 5 + 10_000  # work charged, near the allowance


def test_every_mip_runs_without_rins_and_rens() -> None:
    model = market_split()
    for name in ("mip_heuristic_run_rins", "mip_heuristic_run_rens"):
        assert model.h.getOptionValue(name)[1] is False


def test_a_stopped_run_with_a_wrong_point_stays_stopped_and_drops_the_point(monkeypatch: pytest.MonkeyPatch) -> None:
    model, start, _ = knapsack()
    real_run = LinearModel._run

    def stopped_with_an_infeasible_point(self: LinearModel, time_limit: float, start_: np.ndarray | None) -> Solve:
        res = real_run(self, time_limit, start_)
        return replace(res, status="time_limit", x=np.ones(8))  # every item: over the budget

    monkeypatch.setattr(LinearModel, "_run", stopped_with_an_infeasible_point)
    res = model.solve(1e6, start)
    assert res.status == "time_limit" and res.x is None and "row" in res.detail


def test_models_on_one_matrix_share_its_dense_copy_and_a_changed_model_checks_its_own() -> None:
    """Two models on one Colwise check HiGHS's answers with one read-only dense copy of it; a model that adds
    a row checks against its own matrix, and the shared copy stays as it was."""
    from setupfix.optimize.exact.highs import Colwise

    shared = Colwise.of(np.array([[1.0, 1.0], [1.0, -1.0]]))
    models = [
        LinearModel(
            np.array([-1.0, -1.0]), shared, np.full(2, -INF), np.array([4.0, 1.0]), np.zeros(2), np.full(2, 10.0)
        )
        for _ in range(2)
    ]
    for model in models:
        assert model.solve(5.0).status == "optimal"
    dense, absolute = shared.dense()
    assert not dense.flags.writeable and not absolute.flags.writeable
    np.testing.assert_array_equal(absolute, np.abs(dense))
    models[1].add_rows(np.array([[1.0, 0.0]]), np.array([-INF]), np.array([1.0]))  # x0 ≤ 1
    res = models[1].solve(5.0)
    assert res.status == "optimal" and res.x is not None and res.x[0] <= 1.0 + 1e-9
    assert res.objective == pytest.approx(-4.0)
    assert shared.dense()[0].shape == (2, 2) and shared.dense()[0] is dense
