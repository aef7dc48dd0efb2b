"""Capability indices against a published worked example, a per-element computation and a simulation."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from spc_examples import AMPS, CONCENTRATION

from setupfix.spc import D2, capability, cpk_interval, sigma_overall, sigma_within, split_capability


def _direct(x: list[float], lsl: float, usl: float) -> dict[str, float]:
    """The definitions written out element by element, no numpy."""
    n = len(x)
    mean = sum(x) / n
    mr = sum(abs(x[i] - x[i - 1]) for i in range(1, n)) / (n - 1)
    within = mr / 1.128
    overall = math.sqrt(sum((v - mean) ** 2 for v in x) / (n - 1))
    return {
        "mean": mean,
        "within": within,
        "overall": overall,
        "cp": (usl - lsl) / (6 * within),
        "cpk": min(usl - mean, mean - lsl) / (3 * within),
        "pp": (usl - lsl) / (6 * overall),
        "ppk": min(usl - mean, mean - lsl) / (3 * overall),
        "out": sum(1 for v in x if v < lsl or v > usl),
    }


def test_sigma_within_matches_the_published_example() -> None:
    assert D2 == 1.128
    assert np.mean(CONCENTRATION) == pytest.approx(99.1, abs=0.005)
    assert sigma_within(CONCENTRATION) * D2 == pytest.approx(2.59, abs=0.005)


@pytest.mark.parametrize("seed", range(5))
def test_indices_equal_a_direct_computation(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = list(rng.normal(0.01 * seed, 0.004 + 0.001 * seed, size=30 + 7 * seed))
    lsl, usl = -0.012, 0.015
    c = capability(x, lsl, usl)
    d = _direct(x, lsl, usl)
    assert c.n == len(x)
    assert c.mean == pytest.approx(d["mean"], rel=1e-12)
    assert c.sigma_within == pytest.approx(d["within"], rel=1e-12)
    assert c.sigma_overall == pytest.approx(statistics.stdev(x), rel=1e-12)
    assert sigma_overall(x) == pytest.approx(d["overall"], rel=1e-12)
    for key in ("cp", "cpk", "pp", "ppk"):
        assert getattr(c, key) == pytest.approx(d[key], rel=1e-12), key
    assert c.out_of_tolerance == d["out"]


def test_one_sided_limits_leave_cp_undefined() -> None:
    x = [0.1, 0.3, 0.2, 0.4, 0.25]
    c = capability(x, math.nan, 1.0)
    assert math.isnan(c.cp) and math.isnan(c.pp)
    assert c.cpk == pytest.approx((1.0 - np.mean(x)) / (3 * sigma_within(x)))
    assert c.ppk == pytest.approx((1.0 - np.mean(x)) / (3 * statistics.stdev(x)))
    none = capability([0.2], -1.0, 1.0)
    assert none.n == 1 and math.isnan(none.cpk) and math.isnan(none.cpk_low)


def test_cpk_interval_is_bissell() -> None:
    # Bissell's approximation written out for Ĉpk = 0.625, n = 30 (x̄ = 97, s = 1.6, limits 90 and 100).
    low, high = cpk_interval(0.625, 30)
    half = 1.959964 * math.sqrt(1 / (9 * 30) + 0.625**2 / (2 * 29))
    assert (low, high) == pytest.approx((0.625 - half, 0.625 + half), abs=1e-6)
    assert (low, high) == pytest.approx((0.4247, 0.8253), abs=1e-4)


def test_cpk_interval_matches_a_published_example() -> None:
    # PROC CAPABILITY's Cpk uses the sample standard deviation: setupfix's Ppk.
    c = capability(AMPS, 4.0, 6.0)
    assert c.n == 75
    assert cpk_interval(c.ppk, c.n, confidence=0.90) == pytest.approx((0.328, 0.496), abs=5e-4)


@pytest.mark.slow
def test_cpk_interval_covers_the_true_value_about_95_percent_of_the_time() -> None:
    # A simulation independent of the formula: normal samples of a known process (true Cpk = 1.0).
    rng = np.random.default_rng(7)
    mu, sigma, lsl, usl, n = 0.0, 1.0, -3.5, 3.0, 60
    true_cpk = min(usl - mu, mu - lsl) / (3 * sigma)
    hits = 0
    trials = 2000
    for _ in range(trials):
        x = rng.normal(mu, sigma, n)
        s = statistics.stdev(x)
        est = min(usl - x.mean(), x.mean() - lsl) / (3 * s)
        low, high = cpk_interval(est, n)
        hits += low <= true_cpk <= high
    assert 0.93 <= hits / trials <= 0.97


def test_split_capability_separates_before_and_after() -> None:
    x = np.r_[np.full(10, 0.05) + np.tile([0.001, -0.001], 5), np.tile([0.001, -0.001], 10)]
    after = np.r_[np.zeros(10, bool), np.ones(20, bool)]
    before, later = split_capability(x, after, -0.02, 0.02)
    assert (before.n, later.n) == (10, 20)
    assert before.mean == pytest.approx(0.05) and later.mean == pytest.approx(0.0, abs=1e-15)
    assert before.out_of_tolerance == 10 and later.out_of_tolerance == 0
    assert later.cpk > 1.33 > before.cpk


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=40), st.floats(-100.0, 100.0), st.floats(0.1, 10.0))
def test_indices_do_not_change_when_values_and_limits_shift_and_scale_together(
    x: list[float], shift: float, scale: float
) -> None:
    assume(np.ptp(x) > 1e-3 and np.any(np.diff(x) != 0))
    lsl, usl = -1.5, 1.2
    a = capability(x, lsl, usl)
    b = capability([shift + scale * v for v in x], shift + scale * lsl, shift + scale * usl)
    for key in ("cp", "cpk", "pp", "ppk", "cpk_low", "cpk_high"):
        assert getattr(b, key) == pytest.approx(getattr(a, key), rel=1e-6, abs=1e-9), key
    assert b.out_of_tolerance == a.out_of_tolerance == 0
    assert a.cpk <= a.cp + 1e-12 and a.ppk <= a.pp + 1e-12  # Cpk never exceeds Cp
