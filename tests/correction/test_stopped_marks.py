"""A stopped solve never looks like a genuine hold or a plain apply (issue 37 #14).

Variants of the issue's case: a solve stopped by the work limit whose point lies inside the dead
band (it used to be explained as "every change is within its dead band"), and the verdict cell and
labels every door shows for stopped solves.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from conftest import GUIDE_PINS

import parsers
from setupfix.correction.pose import PosedProblem, pose_problem
from setupfix.correction.recommend import recommend, stopped_where, verdict_cell
from setupfix.correction.safety import Policy
from setupfix.inputs.cycles import read_parts
from setupfix.model import load_model
from setupfix.optimize import OptimizeResult, Stopped, get_optimizer


def guide_posed(report: str = "cycle_02.csv") -> PosedProblem:
    model = load_model(GUIDE_PINS / "model.toml")
    _, parts = read_parts(model, parsers.load_source(GUIDE_PINS / report))
    return pose_problem(model, parts[0])


def stopped_solve(stage: str, reason: str) -> tuple[PosedProblem, OptimizeResult]:
    """The proved answer, relabelled as a stopped one (what a work limit or the guard leaves)."""
    posed = guide_posed()
    result = get_optimizer("exact").solve(posed.guarded)
    assert np.any(result.x)
    return posed, dataclasses.replace(result, status="time_limit", stopped=Stopped(stage, reason), message="stopped")


def with_dead_band(posed: PosedProblem, band: float) -> PosedProblem:
    policy = dataclasses.replace(posed.policy, dead_band=np.full(posed.problem.n_registers, band))
    return dataclasses.replace(posed, policy=policy)


def test_a_stopped_point_inside_the_dead_band_is_not_solved_never_a_dead_band_hold() -> None:
    posed, result = stopped_solve("leximin", "work limit")
    rec = recommend(with_dead_band(posed, 1.0), lambda _problem: result)
    assert rec.verdict == "hold" and not rec.solved and not np.any(rec.x)
    rules = [r.rule for r in rec.rules]
    assert "dead_band" not in rules and "not_solved" in rules
    (rule,) = [r for r in rec.rules if r.rule == "not_solved"]
    assert "within the work limit" in rule.message and "(the leximin stage stopped)" in rule.message
    assert verdict_cell(rec) == "not solved (work limit in the leximin stage)"


def test_a_proved_point_inside_the_dead_band_is_still_a_dead_band_hold() -> None:
    posed = guide_posed()
    rec = recommend(with_dead_band(posed, 1.0), get_optimizer("exact").solve)
    assert rec.verdict == "hold" and rec.solved and [r.rule for r in rec.rules][-1] == "dead_band"
    assert verdict_cell(rec) == "hold" and stopped_where(rec.result) == ""


def test_a_stopped_apply_says_where_it_stopped_in_every_cell() -> None:
    posed, result = stopped_solve("grid optimum", "work limit")
    rec = recommend(posed, lambda _problem: result)
    assert rec.verdict == "apply" and rec.solved
    assert verdict_cell(rec) == "apply (stopped: work limit in the grid optimum stage)"
    (rule,) = [r for r in rec.rules if r.rule == "stopped"]
    assert rule.message.startswith("solve stopped by the work limit (the grid optimum stage stopped)")


def test_the_wall_clock_guard_is_not_solved_within_the_time_limit() -> None:
    posed = guide_posed()
    rec = recommend(posed, get_optimizer("exact", time_limit=1e-9).solve)
    assert rec.verdict == "hold" and not rec.solved and not np.any(rec.x)
    assert rec.result.stopped is not None and rec.result.stopped.reason == "time limit"
    assert verdict_cell(rec).startswith("not solved (time limit in the ")
    (rule,) = [r for r in rec.rules if r.rule == "not_solved"]
    assert "not solved within the time limit" in rule.message and "--time-limit" in rule.message


def test_policy_neutral_has_no_dead_band() -> None:  # the helper above relies on it
    posed = guide_posed()
    assert not np.any(Policy.neutral(posed.problem).dead_band)
