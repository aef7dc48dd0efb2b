"""The verdict around a solve that did not finish, on real problems stopped by a tiny time limit
(setupfix.safety.recommend, stopped_rule)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import GUIDE_PINS
from optimize.test_exact_robust import shop_problem

from setupfix.model import load_model
from setupfix.optimize import get_optimizer
from setupfix.pipeline.cycles import read_parts
from setupfix.pose import pose_policy, pose_problem
from setupfix.safety import STOPPED, Policy, recommend, short_list, stopped_rule

import parsers


def test_a_solve_stopped_before_any_proof_is_not_solved_never_no_change_needed():
    problem = shop_problem(60, 600, 2)  # the LP bound alone takes longer than 1e-4 s
    rec = recommend(pose_policy(problem, Policy.neutral(problem)), get_optimizer("exact", time_limit=1e-4).solve)
    assert rec.result.status == "time_limit" and rec.result.extra["stopped"]["stage"] == "lp bound"
    assert rec.verdict == "hold" and not rec.solved and not np.any(rec.x)
    (rule,) = [r for r in rec.rules if r.rule == "not_solved"]
    assert "not solved within the time limit" in rule.message and "no change needed" in rule.message  # "not ..."
    done = recommend(pose_policy(problem, Policy.neutral(problem)), get_optimizer("exact", time_limit=60).solve)
    assert done.solved and done.result.status == "optimal" and "not_solved" not in [r.rule for r in done.rules]


def guide_posed(report: str = "cycle_01.csv"):
    model = load_model(GUIDE_PINS / "model.toml")
    _, parts = read_parts(model, parsers.load_source(GUIDE_PINS / report))
    return pose_problem(model, parts[0])


def test_a_stopped_solve_that_still_improves_is_applied_with_what_is_certified():
    posed = guide_posed()
    rec = recommend(posed, get_optimizer("exact", time_limit=1e-9).solve)
    assert rec.result.status in STOPPED and rec.result.extra["stopped"]["stage"] == "grid optimum"
    assert rec.verdict == "apply" and rec.solved
    (rule,) = [r for r in rec.rules if r.rule == "stopped"]
    gap = rec.result.bound - rec.result.margin_after
    assert f"within {gap:.4f} of the best possible" in rule.message
    assert rec.result.margin_after > posed.guarded.margin_before  # verified better than no correction


def test_stopped_rule_states_the_certified_norm_ratio():
    posed = guide_posed()
    result = get_optimizer("exact").solve(posed.guarded)
    result.status = "time_limit"
    result.extra.update({"stopped": {"stage": "least norm", "reason": "time limit"}, "norm_ratio_max": 1.25})
    rule = stopped_rule(result, recommended=True)
    assert rule.rule == "stopped" and "at most 1.250× the least norm" in rule.message
    assert "least norm stage" in rule.message and "best possible" not in rule.message
    failed = stopped_rule(result, recommended=False)
    assert failed.rule == "not_solved" and "not solved within the time limit" in failed.message
    result.status = "solver_error"
    assert "the solver failed" in stopped_rule(result, recommended=False).message


@pytest.mark.parametrize(("n", "text"), [(0, ""), (1, "A0"), (4, "A0, A1, A2, A3"),
                                         (744, "A0, A1, A2, … and 741 more")])
def test_short_list_names_the_first_few_and_counts_the_rest(n, text):
    assert short_list(f"A{i}" for i in range(n)) == text

