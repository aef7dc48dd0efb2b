"""Cuckoo search (CS) of Yang & Deb (2009) on the register grid.

The algorithm the thermal-error paper (Abdulshahed et al. 2017) sets against PSO,
offered here on the setup-correction problem for the same comparison.  The search
itself is :func:`setupfix.search.cuckoo_search` (one implementation, shared with
the thermal calibration); this class runs it on the register grid
(:class:`~setupfix.optimize.base.GridSpace`: every move snapped onto the grid
inside the bounds, fixed registers never move), minimising −f.

Each iteration evaluates 2 × 25 solutions.  Stryczek's paper does not use CS, so
no budget is given; the default 5,000 solutions equals CRIPSO's and the GA's.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from setupfix.core.params import Constraint, Interval
from setupfix.optimize.base import POPULATION, Evaluator, GridObjective, GridSpace, Metaheuristic
from setupfix.optimize.problem import CorrectionProblem
from setupfix.search import cuckoo_search

__all__ = ["CuckooSearch"]


class CuckooSearch(Metaheuristic):
    """Yang–Deb cuckoo search on the register grid.

    Parameters
    ----------
    n_nests : int, default=25
    pa : float, default=0.25
        Discovery rate of alien eggs.
    alpha : float, default=0.01
        Scale of the Lévy flight relative to the distance to the best nest.
    beta : float, default=1.5
        Lévy index.
    n_solutions : int, default=5_000
    seed : int, optional
    """

    name = "cs"
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        **Metaheuristic._parameter_constraints,
        "n_nests": POPULATION,
        "pa": [Interval(float, 0.0, 1.0)],
        "alpha": [Interval(float, 0.0, 10.0, closed="right")],
        "beta": [Interval(float, 0.0, 2.0, closed="right")],  # a Lévy-stable index
    }

    def __init__(
        self,
        *,
        n_nests: int = 25,
        pa: float = 0.25,
        alpha: float = 0.01,
        beta: float = 1.5,
        n_solutions: int = 5_000,
        seed: int | None = None,
    ) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_nests = n_nests
        self.pa = pa
        self.alpha = alpha
        self.beta = beta

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        objective = GridObjective(evaluate)
        cuckoo_search(
            objective,
            GridSpace(problem),
            budget=evaluate.remaining,
            rng=rng,
            n_nests=self.n_nests,
            pa=self.pa,
            alpha=self.alpha,
            beta=self.beta,
            observe=objective.observe,
        )
