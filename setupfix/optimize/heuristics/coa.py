"""Cuckoo optimisation algorithm (COA) of Rajabioun (2011), as Stryczek (2014) compares it.

Not the coyote algorithm that shares the acronym.  One iteration (Rajabioun 2011,
sections 2.1–2.6, checked against the author's reference program):

1. every habitat (mature cuckoo) lays between ``min_eggs`` and ``max_eggs`` eggs;
2. within its egg-laying radius (Rajabioun's ELR)
       ELR_i = α · (eggs_i / Σ eggs) · (var_hi − var_lo),
   egg e at radius r_e = ELR_i · U(0, 1) and angle θ_e (evenly spread over
   [0, 2π]) gets, per coordinate, centre ± r_e·cos θ_e + r_e·sin θ_e (random sign);
3. habitats and eggs are evaluated; when more than ``max_cuckoos`` live, only the
   best ``max_cuckoos`` survive (the others are killed);
4. the survivors are grouped by k-means, the group of highest mean profit is the
   best group and its best member the goal;
5. immigration: every survivor moves x ← x + λ · U(0, 1)ⁿ ⊙ (goal − x);
6. elitism: the last habitat is the global best, the one before it the global best
   scaled by U(0, 1)ⁿ; the iteration ends when the positions' total variance
   vanishes or after ``n_iterations``.

Stryczek's settings: at most 40 habitats, 5–10 eggs, 100 iterations (≈ 30,000
solutions).  The other values are Rajabioun's: 5 initial habitats, α = 5 (the
reference program's radius coefficient), λ = 2 (the paper's; the program uses 9).
The number of groups is not given by either; 3 is used (a keyword).  Choices on
the grid: every egg and every migrant is snapped onto the grid inside the bounds;
eggs that land on the same grid point as another candidate are laid once (the
reference program drops duplicate eggs too).  The optional killing of the worst
10 % eggs, described in the paper's text but absent from the program, is not done.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ParameterError
from setupfix.core.params import Constraint, Interval
from setupfix.optimize.base import POPULATION, Evaluator, Metaheuristic, count
from setupfix.optimize.problem import CorrectionProblem

__all__ = ["COA", "lay_eggs", "kmeans", "immigrate"]

Array = npt.NDArray[np.float64]


def lay_eggs(centres: Array, n_eggs: npt.ArrayLike, span: Array, alpha: float, rng: np.random.Generator) -> Array:
    """Egg positions around each habitat (Rajabioun 2011, ELR and egg laying).

    Parameters
    ----------
    centres : ndarray of shape (c, n) [model unit]
    n_eggs : ndarray of shape (c,)
        Eggs of each habitat.
    span : ndarray of shape (n,) [model unit]
        var_hi − var_lo per register (0 for fixed registers).
    alpha : float
        Radius coefficient α of the ELR.

    Returns
    -------
    ndarray of shape (Σ n_eggs, n) [model unit], off the grid
    """
    n_eggs = np.asarray(n_eggs, dtype=np.int64)
    owner = np.repeat(np.arange(centres.shape[0]), n_eggs)
    elr = n_eggs / n_eggs.sum() * alpha  # ELR_i / span
    radius = elr[owner] * rng.random(owner.size)
    # θ_e = linspace(0, 2π, eggs_i) within each habitat
    first = np.repeat(np.cumsum(n_eggs) - n_eggs, n_eggs)
    rank = np.arange(owner.size) - first
    theta = 2.0 * np.pi * rank / np.maximum(n_eggs[owner] - 1, 1)
    sign = np.where(rng.random((owner.size, centres.shape[1])) < 0.5, -1.0, 1.0)
    step = radius[:, None] * (sign * np.cos(theta)[:, None] + np.sin(theta)[:, None])
    eggs: Array = centres[owner] + step * span
    return eggs


def kmeans(x: Array, k: int, rng: np.random.Generator, n_iter: int = 20) -> npt.NDArray[np.int64]:
    """Lloyd's k-means labels of the rows of x, starting from k distinct random rows.

    x : ndarray of shape (m, n) → labels of shape (m,) in 0..k'−1, k' ≤ k non-empty groups
    """
    distinct = np.unique(x, axis=0)
    k = max(1, min(k, distinct.shape[0]))
    centres = distinct[rng.choice(distinct.shape[0], size=k, replace=False)]
    labels = np.zeros(x.shape[0], dtype=np.int64)
    for it in range(n_iter):
        d2 = ((x[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
        new = np.argmin(d2, axis=1)
        if it and np.array_equal(new, labels):
            break
        labels = new
        for j in range(k):
            members = x[labels == j]
            if members.size:
                centres[j] = members.mean(axis=0)
    return np.unique(labels, return_inverse=True)[1].astype(np.int64)


def immigrate(x: Array, goal: Array, motion: float, rng: np.random.Generator) -> Array:
    """Move habitats towards the goal: x + λ · U(0, 1)ⁿ ⊙ (goal − x) (Rajabioun 2011, migration).

    x : ndarray of shape (c, n); goal : ndarray of shape (n,) → ndarray of shape (c, n)
    """
    return x + motion * rng.random(x.shape) * (goal - x)


class COA(Metaheuristic):
    """Rajabioun's cuckoo optimisation algorithm on the register grid.

    Parameters
    ----------
    initial_cuckoos : int, default=5
    max_cuckoos : int, default=40
        Habitats alive at most.
    min_eggs, max_eggs : int, default=5, 10
        Eggs per habitat, drawn uniformly (both inclusive).
    radius_coeff : float, default=5.0
        α of the egg-laying radius.
    motion_coeff : float, default=2.0
        λ of the immigration.
    n_clusters : int, default=3
        Groups of the k-means step.
    n_iterations : int, default=100
    n_solutions : int, default=40_000
        A cap only: with the defaults the ``n_iterations`` end first (the run length the
        module docstring gives; ``tests/optimize/test_coa.py`` measures it).
    seed : int, optional
    """

    name = "coa"
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        **Metaheuristic._parameter_constraints,
        "initial_cuckoos": POPULATION,
        "max_cuckoos": POPULATION,
        "min_eggs": count(1, 1000),
        "max_eggs": count(1, 1000),
        "radius_coeff": [Interval(float, 0.0, 100.0, closed="right")],
        "motion_coeff": [Interval(float, 0.0, 100.0, closed="right")],
        "n_clusters": count(1, 1000),
        "n_iterations": count(1, 100_000),
    }

    def validate_params(self) -> None:
        """The declared ranges, and min_eggs ≤ max_eggs."""
        super().validate_params()
        if self.min_eggs > self.max_eggs:
            raise ParameterError(f"COA: min_eggs must be at most max_eggs ({self.max_eggs}), got {self.min_eggs}")

    def __init__(
        self,
        *,
        initial_cuckoos: int = 5,
        max_cuckoos: int = 40,
        min_eggs: int = 5,
        max_eggs: int = 10,
        radius_coeff: float = 5.0,
        motion_coeff: float = 2.0,
        n_clusters: int = 3,
        n_iterations: int = 100,
        n_solutions: int = 40_000,
        seed: int | None = None,
    ) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.initial_cuckoos = initial_cuckoos
        self.max_cuckoos = max_cuckoos
        self.min_eggs = min_eggs
        self.max_eggs = max_eggs
        self.radius_coeff = radius_coeff
        self.motion_coeff = motion_coeff
        self.n_clusters = n_clusters
        self.n_iterations = n_iterations

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        n = problem.n_registers
        span = problem.ub - problem.lb
        centres = problem.sample(rng, self.initial_cuckoos)
        best_x, best_f = centres[0].copy(), -np.inf
        for _ in range(self.n_iterations):
            if evaluate.remaining <= 0:
                break
            eggs_per = rng.integers(self.min_eggs, self.max_eggs + 1, size=centres.shape[0])
            eggs = problem.snap(lay_eggs(centres, eggs_per, span, self.radius_coeff, rng))
            # Habitats first, then eggs; a grid point is laid (and evaluated) once.
            candidates = np.vstack([centres, eggs])
            _, first = np.unique(candidates, axis=0, return_index=True)
            candidates = candidates[np.sort(first)][: evaluate.remaining]
            f = evaluate(candidates)
            order = np.argsort(-f, kind="stable")[: self.max_cuckoos]
            alive, alive_f = candidates[order], f[order]
            if alive_f[0] > best_f:
                best_x, best_f = alive[0].copy(), float(alive_f[0])
            if float(np.var(alive, axis=0).sum()) < 1e-13:
                break  # the population has collapsed onto one point
            labels = kmeans(alive, self.n_clusters, rng)
            means = np.bincount(labels, weights=alive_f) / np.bincount(labels)
            group = np.flatnonzero(labels == int(np.argmax(means)))
            goal = alive[group[np.argmax(alive_f[group])]]
            centres = problem.snap(immigrate(alive, goal, self.motion_coeff, rng))
            centres[-1] = best_x
            if centres.shape[0] > 1:
                centres[-2] = problem.snap(rng.random(n) * best_x)
