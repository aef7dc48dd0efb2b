"""Covariates of a series: corrections in effect, parts since a tool change, temperatures joined."""

from __future__ import annotations

import numpy as np

from setupfix.diagnose.covariates import applied_at, join_temperatures, parts_since_change


def test_applied_at_takes_every_row_at_or_before_the_part() -> None:
    rng = np.random.default_rng(1)
    log_t = np.round(rng.uniform(0, 10, 30), 1)
    regs = rng.integers(0, 4, 30)
    deltas = rng.normal(size=30)
    times = np.concatenate([np.round(rng.uniform(-1, 11, 20), 1), log_t[:5]])  # exact ties included
    got = applied_at(times, log_t, regs, deltas, 4)
    for k, t in enumerate(times):  # brute force: a part machined at t had every row with timestamp <= t
        want = np.zeros(4)
        for tl, r, d in zip(log_t, regs, deltas, strict=True):
            if tl <= t:
                want[r] += d
        np.testing.assert_allclose(got[k], want, atol=1e-12)


def test_parts_since_change_counts_earlier_cycles_after_the_last_change() -> None:
    times = np.arange(10.0)
    changes = [np.array([3.5, 7.0]), np.array([])]
    got = parts_since_change(times, changes)
    # tool 0 changed before cycle 4 and at the start of cycle 7 (a change at t counts for the part at t)
    assert got[:, 0].tolist() == [0, 1, 2, 3, 0, 1, 2, 0, 1, 2]
    assert got[:, 1].tolist() == list(range(10))


def test_temperature_joined_at_or_just_before() -> None:
    st = np.array([0.0, 1.0, 2.0])
    samples = np.array([[10.0], [11.0], [12.0]])
    got = join_temperatures(np.array([-0.5, 0.0, 0.99, 1.0, 5.0]), st, samples)
    assert got[:, 0].tolist() == [10.0, 10.0, 10.0, 11.0, 12.0]
