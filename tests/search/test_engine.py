"""Every search of setupfix.search on a box: seeded, budgeted, inside the space."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.core.errors import ParameterError
from setupfix.search import (
    Box,
    SearchResult,
    cuckoo_search,
    generator,
    particle_swarm,
    roulette_ga,
    tournament_ga,
)
from setupfix.search.space import Array

SEARCHES = {
    "cs": lambda **kw: cuckoo_search(n_nests=7, **kw),
    "pso-sync": lambda **kw: particle_swarm(n_particles=7, **kw),
    "pso-async": lambda **kw: particle_swarm(n_particles=7, asynchronous=True, coefficients=None, **kw),
    "tournament-ga": lambda **kw: tournament_ga(population=7, **kw),
    "roulette-ga": lambda **kw: roulette_ga(pop_size=7, **kw),
}
BOX = Box.of([-1.3, -0.7, 0.0], [2.9, 1.1, 0.0])  # the last coordinate is fixed
TARGET = np.array([0.3, 0.3, 0.0])


def _run(name: str, seed: int, budget: int) -> tuple[SearchResult, int]:
    seen: list[int] = []

    def objective(x: Array) -> Array:
        assert np.all(x >= BOX.lower) and np.all(x <= BOX.upper)
        values: Array = np.sum((x - TARGET) ** 2, axis=1)
        return values

    res = SEARCHES[name](
        objective=objective, space=BOX, budget=budget, rng=generator(seed), observe=lambda x, v: seen.append(len(x))
    )
    return res, sum(seen)


@pytest.mark.parametrize("name", SEARCHES)
def test_seeded_budgeted_and_inside_the_box(name: str) -> None:
    a, counted = _run(name, 3, 101)
    b, _ = _run(name, 3, 101)
    c, _ = _run(name, 4, 101)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.history, b.history)
    assert not np.array_equal(a.x, c.x)
    assert a.n_evaluations == counted == 101  # a budget that is no multiple of the population
    assert a.x[2] == 0.0 and a.fun == pytest.approx(np.sum((a.x - TARGET) ** 2))
    assert np.all(np.diff(a.history) <= 0) and a.history[-1] == a.fun
    assert a.fun < 0.05


def test_no_unseeded_generator() -> None:
    assert generator(None).random() == np.random.default_rng(0).random()
    g = np.random.default_rng(9)
    assert generator(g) is g


def test_bad_box_and_budget_are_parameter_errors() -> None:
    with pytest.raises(ParameterError, match="lower <= upper"):
        Box.of([1.0], [0.0])
    with pytest.raises(ParameterError, match="budget must be an int in"):
        cuckoo_search(lambda x: x[:, 0], BOX, budget=0, rng=generator(0))
