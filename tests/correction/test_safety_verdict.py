"""The verdict around a solve that did not finish, on real problems stopped by a small work limit or the
wall-clock guard (setupfix.correction.recommend.recommend, stopped_rule)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pytest
from conftest import GUIDE_PINS
from optimize.test_exact_robust import shop_problem

import parsers
from setupfix.correction.explain import fit_registers, leave_one_out
from setupfix.correction.pose import PosedProblem, pose_policy, pose_problem
from setupfix.correction.recommend import recommend, stopped_rule
from setupfix.correction.safety import STOPPED, Policy, short_list
from setupfix.inputs.cycles import read_parts
from setupfix.model import PartMeasurement, ProcessModel, load_model
from setupfix.optimize import CorrectionProblem, Stopped, get_optimizer
from setupfix.optimize.exact import ExactSettings

if TYPE_CHECKING:
    from setupfix.usecases.requests import CycleCorrection


def test_a_solve_stopped_before_any_proof_is_not_solved_never_no_change_needed() -> None:
    problem = shop_problem(60, 600, 2)  # the LP bound alone takes longer than 1e-4 s
    rec = recommend(pose_policy(problem, Policy.neutral(problem)), get_optimizer("exact", time_limit=1e-4).solve)
    assert rec.result.status == "time_limit" and rec.result.stopped == Stopped("lp bound", "time limit")
    assert rec.verdict == "hold" and not rec.solved and not np.any(rec.x)
    (rule,) = [r for r in rec.rules if r.rule == "not_solved"]
    assert "not solved within the time limit" in rule.message and "no change needed" in rule.message  # "not ..."
    # the paper's objective: proved within the limit at this size (leximin's later levels are bench work)
    done = recommend(
        pose_policy(problem, Policy.neutral(problem)), get_optimizer("exact", objective="paper", time_limit=60).solve
    )
    assert done.solved and done.result.status == "optimal" and "not_solved" not in [r.rule for r in done.rules]


def guide_posed(report: str = "cycle_01.csv") -> PosedProblem:
    model = load_model(GUIDE_PINS / "model.toml")
    _, parts = read_parts(model, parsers.load_source(GUIDE_PINS / report))
    return pose_problem(model, parts[0])


def test_a_stopped_solve_that_still_improves_is_applied_with_what_is_certified() -> None:
    """A work limit (the settings', the same under any load) stops the grid-optimum stage: the best point
    found is applied with what is certified, and says it was the work limit."""
    problem = shop_problem(60, 400, 2)
    posed = pose_policy(problem, Policy.neutral(problem))
    solve = get_optimizer("exact", objective="paper", settings=ExactSettings(work_limit=5000.0)).solve
    rec = recommend(posed, solve)
    assert rec.result.status in STOPPED and rec.result.stopped == Stopped("grid optimum", "work limit")
    assert rec.verdict == "apply" and rec.solved
    (rule,) = [r for r in rec.rules if r.rule == "stopped"]
    assert rec.result.bound is not None
    gap = rec.result.bound - rec.result.margin_after
    assert f"within {gap:.4f} of the best possible" in rule.message
    assert "stopped by the work limit" in rule.message and "time limit" not in rule.message
    assert rec.result.margin_after > posed.guarded.margin_before  # verified better than no correction
    np.testing.assert_array_equal(recommend(posed, solve).x, rec.x)  # the same answer on every run


def test_stopped_rule_states_the_certified_norm_ratio() -> None:
    posed = guide_posed()
    result = get_optimizer("exact").solve(posed.guarded)
    result = dataclasses.replace(
        result, status="time_limit", stopped=Stopped("least norm", "time limit"), norm_ratio_max=1.25
    )
    rule = stopped_rule(result, recommended=True)
    assert rule.rule == "stopped" and "at most 1.250× the least norm" in rule.message
    assert "least norm stage" in rule.message and "best possible" not in rule.message
    failed = stopped_rule(result, recommended=False)
    assert failed.rule == "not_solved" and "not solved within the time limit" in failed.message
    result = dataclasses.replace(result, status="solver_error")
    assert "the solver failed" in stopped_rule(result, recommended=False).message


@pytest.mark.parametrize(
    ("n", "text"), [(0, ""), (1, "A0"), (4, "A0, A1, A2, A3"), (744, "A0, A1, A2, … and 741 more")]
)
def test_short_list_names_the_first_few_and_counts_the_rest(n: int, text: str) -> None:
    assert short_list(f"A{i}" for i in range(n)) == text


# -- deviations beyond the reject band: gross, or a setup error the registers explain -----------------------------


def guide_part() -> tuple[ProcessModel, PartMeasurement]:
    model = load_model(GUIDE_PINS / "model.toml")
    _, parts = read_parts(model, parsers.load_source(GUIDE_PINS / "cycle_01.csv"))
    return model, parts[0]


def corrected(model: ProcessModel, part: PartMeasurement, deviation: npt.NDArray[np.float64]) -> CycleCorrection:
    from setupfix.usecases.correct import correct_cycle
    from setupfix.usecases.requests import CorrectRequest

    return correct_cycle(CorrectRequest(model), dataclasses.replace(part, deviation=deviation))


def test_a_wks_entered_wrong_is_named_with_its_amount_not_rejected_as_a_broken_tool() -> None:
    model, part = guide_part()
    composite = CorrectionProblem.from_part(model, part).composite
    j = [r.id for r in model.registers].index("W2")  # G55: station P2 at B0
    cycle = corrected(model, part, part.deviation + 0.35 * composite[j])
    rec = cycle.recommendation
    assert rec.verdict == "hold" and not rec.x.any() and rec.solved
    (rule,) = [r for r in rec.rules if r.rule == "setup_error"]
    assert rule.registers == ("W2",) and "reject" not in [r.rule for r in rec.rules]
    found = re.search(r"G55 looks off by ([-+]\d+\.\d+) mm; beyond the per-step limit 0\.1", rule.message)
    assert found is not None
    amount = float(found[1])
    # the correction that centres P2's dimensions: −0.35 plus what cycle 01 itself needs there (a few hundredths)
    assert amount == pytest.approx(-0.35, abs=0.05)
    assert rec.alarm.startswith("SETUP ERROR: G55 looks off by")
    assert set(rule.dimensions) == {
        d
        for d, v in zip(cycle.problem.dimension_ids, part.deviation + 0.35 * composite[j], strict=True)
        if abs(v) > 0.3
    }


def test_a_single_broken_dimension_still_rejects_without_a_setup_error() -> None:
    model, part = guide_part()
    deviation = part.deviation.copy()
    deviation[0] = -0.9
    rec = corrected(model, part, deviation).recommendation
    assert rec.verdict == "reject" and [r.rule for r in rec.rules] == ["reject"]
    assert rec.rules[0].dimensions == ("P1D1",) and "P1 D1" in rec.alarm and "G5" not in rec.alarm


def test_leave_one_out_equals_refitting_without_each_dimension() -> None:
    rng = np.random.default_rng(4)
    c = rng.choice([-1.0, 0.0, 0.0, 1.0], size=(5, 14))
    r = rng.normal(0, 0.1, 14)
    loo = leave_one_out(c, r)
    for q in range(14):
        keep = np.arange(14) != q
        x = fit_registers(c, r, keep)
        # independent: numpy's least squares on the others (ridge 1e-9 is far below these residuals)
        x_ls = -np.linalg.lstsq(c[:, keep].T, r[keep], rcond=None)[0]
        np.testing.assert_allclose(c[:, keep].T @ x, c[:, keep].T @ x_ls, atol=1e-6)
        assert loo[q] == pytest.approx(r[q] + c[:, q] @ x, abs=1e-6)


def test_an_alarm_over_hundreds_of_dimensions_is_one_short_line_the_json_keeps_them_all(tmp_path: Path) -> None:
    from shop_model import write_shop

    model_path, report = write_shop(tmp_path, m=600)
    model = load_model(model_path)
    _, parts = read_parts(model, parsers.load_source(report))
    rng = np.random.default_rng(1)
    deviation = rng.choice([-0.6, 0.6], parts[0].deviation.size)  # signs at random: no register explains them
    cycle = corrected(model, parts[0], deviation)
    rec = cycle.recommendation
    assert rec.verdict == "reject" and len(rec.alarm) < 300 and "\n" not in rec.alarm
    assert re.search(r"600 dimension\(s\) beyond the reject band .*: SP_000, SP_001, SP_002, … and 597 more", rec.alarm)
    assert len(rec.rules[-1].dimensions) == 600

    from setupfix.usecases.contract import cycle_json
    from setupfix.views.present import format_correction

    assert len(cycle_json(cycle)["rules"][-1]["dimensions"]) == 600
    assert max(len(line) for line in format_correction(cycle).splitlines()) < 400
