"""Cuckoo search core: Mantegna's Lévy steps and the greedy nest replacement (minimising)."""

from __future__ import annotations

import numpy as np

from setupfix.search.cs import greedy, levy_steps, mantegna_sigma


def test_mantegna_sigma_for_beta_one_and_a_half() -> None:
    assert abs(mantegna_sigma(1.5) - 0.6966) < 1e-4
    assert abs(mantegna_sigma(1.0) - 1.0) < 1e-12  # Cauchy case: σ_u = 1


def test_levy_steps_have_the_tail_index_beta() -> None:
    steps = np.abs(levy_steps((1_000_000,), 1.5, np.random.default_rng(0)))
    # P(|L| > x) ∝ x^(−β): a decade further out, the tail is 10^(−1.5) ≈ 0.032 as heavy
    ratio = np.mean(steps > 200.0) / np.mean(steps > 20.0)
    assert 0.022 < ratio < 0.045
    gauss = np.abs(np.random.default_rng(0).normal(size=1_000_000))
    assert np.mean(steps > 20.0) > 1000 * np.mean(gauss > 5.0)


def test_greedy_keeps_equal_or_better() -> None:
    x, x_new = np.zeros((3, 2)), np.ones((3, 2))
    kept, kept_f = greedy(x, np.array([1.0, 2.0, 3.0]), x_new, np.array([1.5, 2.0, 2.5]))
    assert kept.tolist() == [[0, 0], [1, 1], [1, 1]]
    assert kept_f.tolist() == [1.0, 2.0, 2.5]
