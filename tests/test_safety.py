"""Each safety rule's effect on a recommendation (setupfix.safety, posed by setupfix.pose), on small problems
solved exactly."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.safety import (
    Policy,
    apply_gain,
    cumulative_bounds,
    ewma,
    guard_limits,
    harmed_mask,
    reject_mask,
)
from setupfix.pose import pose_policy
from setupfix.safety import recommend as recommend_posed

SOLVE = get_optimizer("exact").solve


def problem(composite, deviation, lower, upper, limit=0.1, h=0.001):
    c = np.atleast_2d(np.asarray(composite, dtype=float))
    n, m = c.shape
    return CorrectionProblem(composite=c, deviation=np.asarray(deviation, float), lower=np.asarray(lower, float),
                             upper=np.asarray(upper, float), lb=np.full(n, -limit), ub=np.full(n, limit),
                             resolution=h, register_ids=tuple(f"R{i}" for i in range(n)),
                             dimension_ids=tuple(f"D{j}" for j in range(m)))


def policy(p, **kw):
    return dataclasses.replace(Policy.neutral(p), **{k: np.asarray(v, float) if k != "guard_band" else v
                                                    for k, v in kw.items()})


def recommend(p, pol, solve, *, measured=None, **kw):
    """The rules around ``solve`` on ``p`` posed with ``pol`` (setupfix.pose: guard band, bounds, costs)."""
    return recommend_posed(pose_policy(p, pol, measured=measured), solve, **kw)


def rules(rec):
    return [r.rule for r in rec.rules]


# one register moving two dimensions by +1: A (±0.05) measured 0, B (±0.1) measured -0.1
TWO = dict(composite=[[1.0, 1.0]], deviation=[0.0, -0.1], lower=[-0.05, -0.1], upper=[0.05, 0.1])


def test_neutral_policy_is_the_plain_optimum():
    p = problem(**TWO)
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.verdict == "apply" and rec.rules == ()
    assert rec.x == pytest.approx([0.025])  # 0.05 − x = x


def test_reject_band_gives_no_correction_and_names_the_dimension():
    p = problem([[1.0, 1.0]], [0.0, -0.35], [-0.05, -0.1], [0.05, 0.1])
    rec = recommend(p, policy(p, reject_band=[0.2, 0.2]), SOLVE, names={"D1": "Bore 1"})
    assert rec.verdict == "reject" and not rec.x.any()
    assert rules(rec) == ["reject"] and rec.rules[0].dimensions == ("D1",)
    assert "Bore 1" in rec.alarm
    inside = recommend(p, policy(p, reject_band=[0.3, 0.3]), SOLVE)
    assert inside.verdict != "reject"


def test_dead_band_turns_a_small_change_into_hold():
    p = problem([[1.0]], [0.002], [-0.1], [0.1])
    held = recommend(p, policy(p, dead_band=[0.003]), SOLVE)
    assert held.verdict == "hold" and not held.x.any() and rules(held) == ["dead_band"]
    applied = recommend(p, policy(p, dead_band=[0.001]), SOLVE)
    assert applied.verdict == "apply" and applied.x == pytest.approx([-0.002])


def test_gain_applies_the_fraction_rounded_towards_zero():
    p = problem([[1.0]], [0.047], [-0.1], [0.1])
    rec = recommend(p, policy(p, gain=[0.5]), SOLVE)
    assert rec.x == pytest.approx([-0.023]) and "gain" in rules(rec)  # 0.5 · −0.047 towards zero


def test_gain_never_moves_an_in_tolerance_dimension_out():
    rng = np.random.default_rng(3)
    for _ in range(30):
        c = rng.choice([-1.0, 0.0, 1.0], size=(3, 6))
        dev = rng.uniform(-0.12, 0.12, 6)
        p = problem(c, dev, np.full(6, -0.1), np.full(6, 0.1))
        full = recommend(p, Policy.neutral(p), SOLVE)
        part = recommend(p, policy(p, gain=np.full(3, 0.6)), SOLVE)
        both_in = ~harmed_mask(dev, p.predicted(full.x), p.lower, p.upper)
        assert not (harmed_mask(dev, p.predicted(part.x), p.lower, p.upper) & both_in).any()


def test_cumulative_limit_tightens_the_step_and_flags_the_register():
    p = problem([[1.0]], [-0.08], [-0.1], [0.1])
    rec = recommend(p, policy(p, cumulative_limit=[0.1], cumulative=[0.07]), SOLVE)
    assert rec.x == pytest.approx([0.03])  # 0.07 already applied since the reset
    assert rules(rec) == ["cumulative_limit", "clamp"] and rec.at_limit == ("R0",)
    lb, ub = cumulative_bounds(np.array([-0.1]), np.array([0.1]), np.array([0.15]), np.array([0.1]), 0.001)
    assert lb == pytest.approx([-0.1]) and ub == pytest.approx([0.0])  # beyond: may only move back


def test_per_step_clamp_is_flagged():
    p = problem([[1.0]], [-0.09], [-0.1], [0.1], limit=0.05)
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.x == pytest.approx([0.05]) and rec.at_limit == ("R0",) and rules(rec) == ["clamp"]


def test_guard_band_optimises_on_the_shrunk_limits():
    p = problem(**TWO)
    rec = recommend(p, policy(p, uncertainty=[0.02, 0.0]), SOLVE)
    assert rec.x == pytest.approx([0.015])  # 0.03 − x = x
    assert rules(rec) == ["guard_band"] and rec.rules[0].dimensions == ("D0",)
    lo, up = guard_limits(np.array([-0.1]), np.array([0.1]), np.array([0.2]))
    assert lo == up == pytest.approx([0.0])


def test_no_harm_gives_up_the_hopeless_dimension():
    # the max-min optimum (x = +0.1) would push B from +0.05 to +0.15; the exact optimiser's triage
    # (issue 13) already gives A up and keeps B in tolerance, and no_harm guards any optimiser that does not
    p = problem([[1.0, 1.0]], [-0.25, 0.05], [-0.1, -0.1], [0.1, 0.1])
    raw = SOLVE(p)
    assert raw.given_up == ("D0",)
    assert harmed_mask(p.deviation, p.predicted(raw.x), p.lower, p.upper).tolist() == [False, False]
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.given_up == ("D0",)
    assert rec.x == pytest.approx([-0.05])  # B centred, A left to the NC program
    assert not harmed_mask(p.deviation, p.predicted(rec.x), p.lower, p.upper).any()


def test_no_harm_holds_when_no_correction_is_harmless():
    # an optimiser that pushes B (in tolerance) out, even once A is given up: nothing may be applied
    p = problem([[1.0, -1.0]], [-0.3, 0.099], [-0.1, -0.1], [0.1, 0.1])
    rec = recommend(p, Policy.neutral(p), lambda q: dataclasses.replace(SOLVE(q), x=np.array([-0.05])))
    assert rec.verdict == "hold" and not rec.x.any() and "no_harm" in rules(rec)


def test_register_cost_moves_the_cheap_register():
    p = problem([[1.0], [1.0]], [0.04], [-0.1], [0.1])  # W + T: any split works
    even = recommend(p, Policy.neutral(p), SOLVE)
    assert even.x == pytest.approx([-0.02, -0.02])
    cheap_w = recommend(p, policy(p, cost=[1.0, 100.0]), SOLVE)
    assert abs(cheap_w.x[0]) > abs(cheap_w.x[1])


def test_reject_mask_and_ewma():
    assert reject_mask(np.array([0.31, -0.2, 0.0]), np.full(3, -0.1), np.full(3, 0.1), np.full(3, 0.2)).tolist() \
        == [True, False, False]
    y, prev = np.array([0.04, 0.0]), np.array([0.0, np.nan])
    assert ewma(y, prev, 0.25) == pytest.approx([0.01, 0.0])
    assert ewma(y, None, 0.25) == pytest.approx(y)
    assert apply_gain(np.array([0.0119, -0.0119]), np.array([1.0, 1.0]), 0.001) == pytest.approx([0.011, -0.011])
