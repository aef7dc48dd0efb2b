"""Rajabioun's COA: egg-laying radius, k-means grouping, immigration, iteration budget."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.optimize.heuristics.coa import COA, immigrate, kmeans, lay_eggs


def test_eggs_lie_within_the_egg_laying_radius() -> None:
    rng = np.random.default_rng(0)
    centres = rng.uniform(-0.05, 0.05, (4, 6))
    n_eggs = np.array([5, 10, 7, 8])
    span = np.full(6, 0.2)
    eggs = lay_eggs(centres, n_eggs, span, 5.0, rng)
    assert eggs.shape == (30, 6)
    owner = np.repeat(np.arange(4), n_eggs)
    elr = 5.0 * n_eggs / n_eggs.sum() * 0.2  # ELR = α · eggs_i / Σ eggs · (hi − lo)
    dev = np.abs(eggs - centres[owner])
    # |±r cos θ + r sin θ| ≤ √2 · r ≤ √2 · ELR
    assert np.all(dev <= np.sqrt(2) * elr[owner][:, None] + 1e-15)
    # the habitat with more eggs lays them farther: its radius is larger
    assert dev[owner == 1].max() > dev[owner == 0].max()


def test_kmeans_finds_separated_groups() -> None:
    rng = np.random.default_rng(1)
    blobs = [rng.normal(c, 0.01, (20, 3)) for c in (-1.0, 0.0, 1.0)]
    labels = kmeans(np.vstack(blobs), 3, np.random.default_rng(5))
    groups = labels.reshape(3, 20)
    assert all(len(set(g)) == 1 for g in groups) and len({g[0] for g in groups}) == 3


def test_kmeans_with_fewer_distinct_points_than_groups() -> None:
    x = np.array([[0.0, 1.0]] * 5 + [[1.0, 0.0]] * 3)
    labels = kmeans(x, 3, np.random.default_rng(0))
    assert len(set(labels.tolist())) == 2


def test_immigration_moves_towards_the_goal() -> None:
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (200, 4))
    goal = np.zeros(4)
    moved = immigrate(x, goal, 1.0, rng)
    assert np.all(np.abs(moved) <= np.abs(x) + 1e-15)
    overshoot = immigrate(x, goal, 2.0, rng)  # λ = 2 may pass the goal, never by more than the distance
    assert np.any(np.sign(overshoot) != np.sign(x)) and np.all(np.abs(overshoot) <= np.abs(x) + 1e-15)


def test_paper_run_length() -> None:
    from pathlib import Path

    from setupfix.inputs.cycles import load_parts
    from setupfix.model import load_model
    from setupfix.optimize import CorrectionProblem

    here = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"
    model = load_model(here / "model.toml")
    problem = CorrectionProblem.from_part(model, load_parts(model, here / "cycle_03.csv")[0])
    result = COA(seed=0).solve(problem)
    # Stryczek: 100 iterations with at most 40 habitats and 5–10 eggs ≈ 30,000 solutions
    assert 25_000 <= result.evaluations <= 36_000
    assert result.history is not None and result.history.shape[0] == pytest.approx(100, abs=1)
