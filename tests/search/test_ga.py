"""Elitist GA core: the operators and the (μ + λ) elitism (minimising)."""

from __future__ import annotations

import numpy as np

from setupfix.search.ga import mutate, recombine, survive, tournament


def test_binary_tournament_frequencies() -> None:
    rng = np.random.default_rng(0)
    f = -np.arange(10.0)  # rank j has value −j: larger j is better
    winners = tournament(f, 200_000, rng)
    share = np.bincount(winners, minlength=10) / winners.size
    # best of two draws with replacement: P(win of rank j) = ((j+1)² − j²) / 100
    expected = (2 * np.arange(10) + 1) / 100.0
    assert np.allclose(share, expected, atol=0.004)


def test_recombination_stays_between_the_parents() -> None:
    rng = np.random.default_rng(1)
    p1, p2 = rng.uniform(-1, 1, (500, 7)), rng.uniform(-1, 1, (500, 7))
    child = recombine(p1, p2, rng)
    assert np.all(child >= np.minimum(p1, p2) - 1e-15) and np.all(child <= np.maximum(p1, p2) + 1e-15)
    assert not np.allclose(child, p1) and not np.allclose(child, p2)


def test_mutation_rate_and_range() -> None:
    rng = np.random.default_rng(2)
    x = np.zeros((20_000, 10))
    lb, ub = np.full(10, -0.1), np.full(10, 0.1)
    y = mutate(x, lb, ub, 0.1, rng)
    assert abs(np.mean(y != 0.0) - 0.1) < 0.005
    assert np.all(y >= lb) and np.all(y <= ub)


def test_survival_keeps_the_best() -> None:
    x = np.arange(12.0).reshape(6, 2)
    f = -np.array([3.0, 9.0, 1.0, 9.0, 7.0, 0.0])
    kept, kept_f = survive(x, f, 3)
    assert kept_f.tolist() == [-9.0, -9.0, -7.0]
    assert kept.tolist() == [[2.0, 3.0], [6.0, 7.0], [8.0, 9.0]]
