"""Each safety rule's effect on a recommendation, on small problems solved exactly.

The rules are :mod:`setupfix.correction.safety`; the problems are posed by :mod:`setupfix.correction.pose`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.correction.ewma import ewma
from setupfix.correction.pose import pose_policy
from setupfix.correction.recommend import recommend as recommend_posed
from setupfix.correction.safety import (
    Policy,
    Recommendation,
    apply_gain,
    cumulative_bounds,
    guard_limits,
    harmed_mask,
    reject_mask,
)
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer

SOLVE = get_optimizer("exact").solve


def problem(
    composite: npt.ArrayLike,
    deviation: npt.ArrayLike,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    limit: float = 0.1,
    h: float = 0.001,
) -> CorrectionProblem:
    c = np.atleast_2d(np.asarray(composite, dtype=float))
    n, m = c.shape
    return CorrectionProblem(
        composite=c,
        deviation=np.asarray(deviation, float),
        lower=np.asarray(lower, float),
        upper=np.asarray(upper, float),
        lb=np.full(n, -limit),
        ub=np.full(n, limit),
        resolution=h,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def policy(p: CorrectionProblem, **kw: Any) -> Policy:
    fields: dict[str, Any] = {k: np.asarray(v, float) if k != "guard_band" else v for k, v in kw.items()}
    return dataclasses.replace(Policy.neutral(p), **fields)


def recommend(
    p: CorrectionProblem,
    pol: Policy,
    solve: Callable[[CorrectionProblem], OptimizeResult],
    *,
    measured: npt.NDArray[np.float64] | None = None,
    **kw: Any,
) -> Recommendation:
    """The rules around ``solve`` on ``p`` posed with ``pol`` (setupfix.correction.pose: guard band, bounds, costs)."""
    return recommend_posed(pose_policy(p, pol, measured=measured), solve, **kw)


def rules(rec: Recommendation) -> list[str]:
    return [r.rule for r in rec.rules]


# one register moving two dimensions by +1: A (±0.05) measured 0, B (±0.1) measured -0.1
TWO: dict[str, Any] = dict(composite=[[1.0, 1.0]], deviation=[0.0, -0.1], lower=[-0.05, -0.1], upper=[0.05, 0.1])


def test_neutral_policy_is_the_plain_optimum() -> None:
    p = problem(**TWO)
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.verdict == "apply" and rec.rules == ()
    assert rec.x == pytest.approx([0.025])  # 0.05 − x = x


def test_reject_band_gives_no_correction_and_names_the_dimension() -> None:
    p = problem([[1.0, 1.0]], [0.0, -0.35], [-0.05, -0.1], [0.05, 0.1])
    rec = recommend(p, policy(p, reject_band=[0.2, 0.2]), SOLVE, names={"D1": "Bore 1"})
    assert rec.verdict == "reject" and not rec.x.any()
    assert rules(rec) == ["reject"] and rec.rules[0].dimensions == ("D1",)
    assert "Bore 1" in rec.alarm
    inside = recommend(p, policy(p, reject_band=[0.3, 0.3]), SOLVE)
    assert inside.verdict != "reject"


def test_dead_band_turns_a_small_change_into_hold() -> None:
    p = problem([[1.0]], [0.002], [-0.1], [0.1])
    held = recommend(p, policy(p, dead_band=[0.003]), SOLVE)
    assert held.verdict == "hold" and not held.x.any() and rules(held) == ["dead_band"]
    applied = recommend(p, policy(p, dead_band=[0.001]), SOLVE)
    assert applied.verdict == "apply" and applied.x == pytest.approx([-0.002])


def test_gain_applies_the_fraction_rounded_towards_zero() -> None:
    p = problem([[1.0]], [0.047], [-0.1], [0.1])
    rec = recommend(p, policy(p, gain=[0.5]), SOLVE)
    assert rec.x == pytest.approx([-0.023]) and "gain" in rules(rec)  # 0.5 · −0.047 towards zero


@pytest.mark.slow
def test_gain_never_moves_an_in_tolerance_dimension_out() -> None:
    rng = np.random.default_rng(3)
    for _ in range(30):
        c = rng.choice([-1.0, 0.0, 1.0], size=(3, 6))
        dev = rng.uniform(-0.12, 0.12, 6)
        p = problem(c, dev, np.full(6, -0.1), np.full(6, 0.1))
        full = recommend(p, Policy.neutral(p), SOLVE)
        part = recommend(p, policy(p, gain=np.full(3, 0.6)), SOLVE)
        both_in = ~harmed_mask(dev, p.predicted(full.x), p.lower, p.upper)
        assert not (harmed_mask(dev, p.predicted(part.x), p.lower, p.upper) & both_in).any()


def test_cumulative_limit_tightens_the_step_and_flags_the_register() -> None:
    p = problem([[1.0]], [-0.08], [-0.1], [0.1])
    rec = recommend(p, policy(p, cumulative_limit=[0.1], cumulative=[0.07]), SOLVE)
    assert rec.x == pytest.approx([0.03])  # 0.07 already applied since the reset
    assert rules(rec) == ["cumulative_limit", "clamp"] and rec.at_limit == ("R0",)
    lb, ub = cumulative_bounds(np.array([-0.1]), np.array([0.1]), np.array([0.15]), np.array([0.1]), 0.001)
    assert lb == pytest.approx([-0.1]) and ub == pytest.approx([0.0])  # beyond: may only move back


def test_per_step_clamp_is_flagged() -> None:
    p = problem([[1.0]], [-0.09], [-0.1], [0.1], limit=0.05)
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.x == pytest.approx([0.05]) and rec.at_limit == ("R0",) and rules(rec) == ["clamp"]


def test_guard_band_optimises_on_the_shrunk_limits() -> None:
    p = problem(**TWO)
    rec = recommend(p, policy(p, uncertainty=[0.02, 0.0]), SOLVE)
    assert rec.x == pytest.approx([0.015])  # 0.03 − x = x
    assert rules(rec) == ["guard_band"] and rec.rules[0].dimensions == ("D0",)
    lo, up = guard_limits(np.array([-0.1]), np.array([0.1]), np.array([0.2]))
    assert lo == up == pytest.approx([0.0])


def test_no_harm_gives_up_the_hopeless_dimension() -> None:
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


def test_no_harm_holds_when_no_correction_is_harmless() -> None:
    # an optimiser that pushes B (in tolerance) out, even once A is given up: nothing may be applied
    p = problem([[1.0, -1.0]], [-0.3, 0.099], [-0.1, -0.1], [0.1, 0.1])
    rec = recommend(p, Policy.neutral(p), lambda q: dataclasses.replace(SOLVE(q), x=np.array([-0.05])))
    assert rec.verdict == "hold" and not rec.x.any() and "no_harm" in rules(rec)


def test_register_cost_moves_the_cheap_register() -> None:
    p = problem([[1.0], [1.0]], [0.04], [-0.1], [0.1])  # W + T: any split works
    even = recommend(p, Policy.neutral(p), SOLVE)
    assert even.x == pytest.approx([-0.02, -0.02])
    cheap_w = recommend(p, policy(p, cost=[1.0, 100.0]), SOLVE)
    assert abs(cheap_w.x[0]) > abs(cheap_w.x[1])


def test_reject_mask_and_ewma() -> None:
    assert reject_mask(np.array([0.31, -0.2, 0.0]), np.full(3, -0.1), np.full(3, 0.1), np.full(3, 0.2)).tolist() == [
        True,
        False,
        False,
    ]
    y, prev = np.array([0.04, 0.0]), np.array([0.0, np.nan])
    assert ewma(y, prev, 0.25) == pytest.approx([0.01, 0.0])
    assert ewma(y, None, 0.25) == pytest.approx(y)
    assert apply_gain(np.array([0.0119, -0.0119]), np.array([1.0, 1.0]), 0.001) == pytest.approx([0.011, -0.011])


# --- no harm inside the triage's optimum (issue 22) -------------------------------------------------------


def fourteen_and_seventeen() -> CorrectionProblem:
    """R0 moves A1…A14 (measured +0.09, in) and B1…B15 (−0.15, out); R1 moves C1…C3 (−0.12, out).
    Bringing the B in pushes every A out; the C come in on their own.  The triage without no harm
    brought the 15 B and 3 C in, the re-solve on the A alone then gave the C up too: 14 kept."""
    comp = np.zeros((2, 32))
    comp[0, :29] = 1.0
    comp[1, 29:] = 1.0
    dev = np.r_[np.full(14, 0.09), np.full(15, -0.15), np.full(3, -0.12)]
    return problem(comp, dev, np.full(32, -0.1), np.full(32, 0.1))


def test_triage_keeps_seventeen_where_the_re_solve_kept_fourteen() -> None:
    p = fourteen_and_seventeen()
    rec = recommend(p, Policy.neutral(p), SOLVE)
    m = p.margins(rec.x)
    assert rec.verdict == "apply" and rec.result.status == "optimal"
    assert (m >= 0).sum() == 17  # the 14 A held, the 3 C brought in
    assert rec.given_up == tuple(f"D{j}" for j in range(14, 29))  # the 15 B, read from the answer
    assert rec.result.given_up == rec.given_up
    assert rec.x == pytest.approx([-0.09, 0.1])  # A centred; C as far in as R1's limit allows
    # brute force over the whole grid: no correction keeps more without moving an A out
    k = np.arange(-100, 101) * 0.001
    x = np.stack(np.meshgrid(k, k, indexing="ij"), axis=-1).reshape(-1, 2)
    margins = p.margins(x)
    no_harm = np.all(margins[:, :14] >= 0, axis=1)
    assert (margins[no_harm] >= 0).sum(axis=1).max() == 17
    assert "no_harm" in rules(rec) and "given_up" in rules(rec)


def test_guarded_triage_keeps_the_dimensions_measured_inside_the_real_limits() -> None:
    # B measured at 0.095 (inside ±0.1 but within U = 0.01 of the limit): the guard band alone would let
    # the triage push it out to bring A in; the no-harm floor keeps it inside the real limits
    p = problem([[1.0, 1.0]], [-0.3, 0.095], [-0.1, -0.1], [0.1, 0.1])
    rec = recommend(p, policy(p, uncertainty=[0.0, 0.01]), SOLVE)
    assert not harmed_mask(p.deviation, p.predicted(rec.x), p.lower, p.upper).any()
    assert rec.given_up == ("D0",)
    assert rec.problem.floor == pytest.approx([-np.inf, -0.01])
    assert rec.x == pytest.approx([-0.095])  # B centred (guarded margin 0.09 at the centre)


def test_no_harm_refuses_when_not_even_the_measured_in_tolerance_can_be_kept() -> None:
    # "no change" is outside the register's bounds [+0.01, +0.05]: every step pushes B (+0.095) out
    c = problem([[1.0, 1.0]], [-0.3, 0.095], [-0.1, -0.1], [0.1, 0.1])
    p = dataclasses.replace(c, lb=np.array([0.01]), ub=np.array([0.05]))
    raw = SOLVE(p)
    assert raw.triage is not None and raw.triage.refused and not raw.x.any()
    rec = recommend(p, Policy.neutral(p), SOLVE)
    assert rec.verdict == "hold" and not rec.x.any() and rec.given_up == ()
    assert "no_harm" in rules(rec)


@pytest.mark.parametrize("seed", range(30))
def test_given_up_never_names_a_dimension_predicted_in_tolerance(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, m = 3, 9
    comp = rng.integers(-1, 2, size=(n, m)).astype(float)
    p = problem(comp, np.round(rng.uniform(-0.2, 0.2, m), 4), np.full(m, -0.05), np.full(m, 0.05), limit=0.03, h=0.005)
    pol = policy(p, uncertainty=rng.uniform(0, 0.01, m), gain=rng.choice([1.0, 0.5], n))
    rec = recommend(p, pol, SOLVE)
    predicted = p.predicted(rec.x)
    inside = (predicted >= p.lower - 1e-12) & (predicted <= p.upper + 1e-12)
    named = np.isin(p.dimension_ids, rec.given_up)
    assert not (named & inside).any()
    assert not harmed_mask(p.deviation, predicted, p.lower, p.upper).any()
    raw = rec.result
    if raw.given_up:  # status, bound and δ read from the final answer, over the kept dimensions
        kept = ~np.isin(rec.problem.dimension_ids, raw.given_up)
        assert raw.margin_after == pytest.approx(rec.problem.margins(raw.x)[kept].min(), abs=1e-12)
        assert raw.bound is not None and raw.bound >= raw.margin_after - 1e-9
        assert raw.status == "optimal" and raw.stopped is None
        assert raw.triage is not None and set(raw.triage.given_up) == set(raw.given_up)
