"""Elitist genetic algorithm, the GA of Stryczek's comparison (2014; flow chart in Stryczek 2009).

The paper gives: population 50, gene mutation probability 0.1, 5,000 solutions,
and elitism.  The search is :func:`setupfix.search.tournament_ga` (binary
tournaments, intermediate recombination, uniform redraw mutation, (μ + λ)
survival; see there), run on the register grid
(:class:`~setupfix.optimize.base.GridSpace`: children snapped onto the grid inside
the bounds, fixed registers never move), minimising −f.  Each generation evaluates
λ = 50 children.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from setupfix.core.params import Constraint, Interval
from setupfix.optimize.base import POPULATION, Evaluator, GridObjective, GridSpace, Metaheuristic, count
from setupfix.optimize.problem import CorrectionProblem
from setupfix.search import tournament_ga

__all__ = ["GA"]


class GA(Metaheuristic):
    """Elitist (μ + λ) genetic algorithm on the register grid.

    Parameters
    ----------
    population : int, default=50
        μ, and also λ (children per generation).
    mutation_rate : float, default=0.1
        Probability that a gene is redrawn.
    tournament_size : int, default=2
    n_solutions : int, default=5_000
    seed : int, optional
    """

    name = "ga"
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        **Metaheuristic._parameter_constraints,
        "population": POPULATION,
        "mutation_rate": [Interval(float, 0.0, 1.0)],
        "tournament_size": count(1, 1000),
    }

    def __init__(
        self,
        *,
        population: int = 50,
        mutation_rate: float = 0.1,
        tournament_size: int = 2,
        n_solutions: int = 5_000,
        seed: int | None = None,
    ) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.population = population
        self.mutation_rate = mutation_rate
        self.tournament_size = tournament_size

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        objective = GridObjective(evaluate)
        tournament_ga(
            objective,
            GridSpace(problem),
            budget=evaluate.remaining,
            rng=rng,
            population=self.population,
            mutation_rate=self.mutation_rate,
            tournament_size=self.tournament_size,
            observe=objective.observe,
        )
