"""Elitist genetic algorithm, the GA of Stryczek's comparison (2014; flow chart in Stryczek 2009).

The paper gives: population 50, gene mutation probability 0.1, 5,000 solutions,
and elitism — "the winners of the competition qualify to the next population".
The 2009 flow chart is not available here, so the operators are the textbook ones
for real genes on a grid, each a keyword:

* selection: binary tournaments (the "competition"), parents drawn with replacement;
* crossover: intermediate recombination, child = a ⊙ p1 + (1 − a) ⊙ p2 with a
  uniform per gene (Mühlenbein & Schlierkamp-Voosen 1993), then snapped to the grid;
* mutation: each gene with probability 0.1 is redrawn uniformly in its bounds;
* survival: (μ + λ) — parents and children compete and the best μ = 50 form the
  next population, so the best solution is never lost (elitism).

Each generation evaluates λ = 50 children.  Fixed registers never move.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.optimize._base import Evaluator, Metaheuristic
from setupfix.optimize._problem import CorrectionProblem

__all__ = ["GA", "tournament", "recombine", "mutate", "survive"]

Array = npt.NDArray[np.float64]


def tournament(fitness: Array, n: int, rng: np.random.Generator, size: int = 2) -> npt.NDArray[np.int64]:
    """Indices of n winners of tournaments among ``size`` random individuals.

    fitness : ndarray of shape (μ,), larger is better → ndarray of shape (n,)
    """
    entrants = rng.integers(0, fitness.size, size=(n, size))
    return entrants[np.arange(n), np.argmax(fitness[entrants], axis=1)]


def recombine(p1: Array, p2: Array, rng: np.random.Generator) -> Array:
    """Intermediate recombination a ⊙ p1 + (1 − a) ⊙ p2, a ~ U(0, 1) per gene.

    p1, p2 : ndarray of shape (λ, n) [model unit] → ndarray of shape (λ, n), off the grid
    """
    a = rng.random(p1.shape)
    return a * p1 + (1.0 - a) * p2


def mutate(children: Array, lb: Array, ub: Array, rate: float, rng: np.random.Generator) -> Array:
    """Redraw each gene with probability ``rate`` uniformly in [lb, ub].

    children : ndarray of shape (λ, n) [model unit]; lb, ub : ndarray of shape (n,)
    """
    hit = rng.random(children.shape) < rate
    fresh = rng.uniform(lb, ub, size=children.shape)
    return np.where(hit, fresh, children)


def survive(x: Array, f: Array, mu: int) -> tuple[Array, Array]:
    """(μ + λ) survival: the μ fittest of parents and children, best first (stable on ties).

    x : ndarray of shape (μ + λ, n); f : ndarray of shape (μ + λ,)
    """
    keep = np.argsort(-f, kind="stable")[:mu]
    return x[keep], f[keep]


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

    def __init__(self, *, population: int = 50, mutation_rate: float = 0.1, tournament_size: int = 2,
                 n_solutions: int = 5_000, seed: int | None = None) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.population = population
        self.mutation_rate = mutation_rate
        self.tournament_size = tournament_size

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        mu = max(1, min(self.population, evaluate.remaining))
        x = problem.sample(rng, mu)
        f = evaluate(x)
        while evaluate.remaining > 0:
            lam = min(self.population, evaluate.remaining)
            i = tournament(f, lam, rng, self.tournament_size)
            j = tournament(f, lam, rng, self.tournament_size)
            children = recombine(x[i], x[j], rng)
            children = problem.snap(mutate(children, problem.lb, problem.ub, self.mutation_rate, rng))
            f_children = evaluate(children)
            x, f = survive(np.vstack([x, children]), np.concatenate([f, f_children]), mu)
