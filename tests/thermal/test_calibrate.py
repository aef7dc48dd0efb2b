"""CS, PSO and GA find known optima, respect bounds and are reproducible from a seed."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from setupfix.thermal.calibrate import (
    Array,
    SearchResult,
    cuckoo_search,
    genetic_algorithm,
    mantegna_sigma,
    particle_swarm,
)

SHIFT = np.array([1.5, -2.0, 0.5, 3.0])


def sphere(pop: Array) -> Array:
    values: Array = np.sum((pop - SHIFT) ** 2, axis=1)
    return values


def test_mantegna_sigma() -> None:
    assert mantegna_sigma(1.5) == pytest.approx(0.6966, abs=1e-4)


@pytest.mark.parametrize(
    ("search", "kwargs", "tol"),
    [
        (cuckoo_search, {"n_nests": 25, "pa": 0.25, "n_iter": 300}, 1e-4),
        (particle_swarm, {"n_particles": 25, "n_iter": 300}, 1e-4),
        (genetic_algorithm, {"pop_size": 40, "n_gen": 200, "p_mutation": 0.1}, 1e-1),
    ],
)
def test_finds_shifted_sphere_minimum(
    search: Callable[..., SearchResult], kwargs: dict[str, float], tol: float
) -> None:
    lo, hi = np.full(4, -10.0), np.full(4, 10.0)
    res = search(sphere, lo, hi, rng=np.random.default_rng(0), **kwargs)
    assert res.fun < tol
    np.testing.assert_allclose(res.x, SHIFT, atol=np.sqrt(tol) * 3)
    assert np.all(np.diff(res.history) <= 0)  # best-so-far never worsens
    assert res.history[-1] == pytest.approx(res.fun)


@pytest.mark.parametrize("search", [cuckoo_search, particle_swarm, genetic_algorithm])
def test_bounds_and_reproducibility(search: Callable[..., SearchResult]) -> None:
    lo, hi = np.zeros(4), np.ones(4)  # optimum outside the box: the answer sits on its edge
    seen: list[Array] = []

    def objective(pop: Array) -> Array:
        seen.append(pop.copy())
        return sphere(pop)

    a = search(objective, lo, hi, rng=np.random.default_rng(5))
    allpop = np.vstack(seen)
    assert allpop.min() >= 0.0 and allpop.max() <= 1.0
    b = search(sphere, lo, hi, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_allclose(a.x, [1.0, 0.0, 0.5, 1.0], atol=0.1)


def test_paper_evaluation_counts() -> None:
    lo, hi = np.full(2, -1.0), np.full(2, 1.0)
    cs = cuckoo_search(sphere_2 := (lambda p: np.sum(p * p, axis=1)), lo, hi, rng=np.random.default_rng(0))
    assert cs.n_evaluations == 25 + 2 * 25 * 100 and cs.history.size == 101
    pso = particle_swarm(sphere_2, lo, hi, rng=np.random.default_rng(0))
    assert pso.n_evaluations == 25 + 25 * 100


def test_infinite_objective_values_lose() -> None:
    def objective(pop: Array) -> Array:
        out: Array = np.sum(pop * pop, axis=1)
        out[pop[:, 0] > 0] = np.inf  # a diverging half of the box
        return out

    res = cuckoo_search(objective, np.full(2, -1.0), np.full(2, 1.0), rng=np.random.default_rng(1))
    assert np.isfinite(res.fun) and res.x[0] <= 0
