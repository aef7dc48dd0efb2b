"""Cuckoo search (CS) of Yang & Deb (2009) with Mantegna's Lévy flights.

The algorithm the thermal-error paper (Abdulshahed et al. 2017) sets against PSO,
offered here on the setup-correction problem for the same comparison.  One
iteration (Yang & Deb 2009, and Yang's reference program of 2009/2014):

1. every nest s makes a new cuckoo by a Lévy flight scaled to its distance from
   the best nest:  s' = s + α · L ⊙ (s − best) ⊙ N(0, 1),  α = 0.01, where L is a
   Lévy step by Mantegna's algorithm (1994), β = 1.5:
       σ_u = [Γ(1+β) sin(πβ/2) / (Γ((1+β)/2) β 2^((β−1)/2))]^(1/β),
       L = u / |v|^(1/β),  u ~ N(0, σ_u²),  v ~ N(0, 1);
   the new cuckoo replaces its nest when it is at least as good (greedy);
2. a fraction of the nests is discovered: each coordinate moves with probability
   1 − p_a by one common U(0, 1) times the difference of two randomly permuted
   nests (the reference program's "empty nests" step), again greedily.

Each iteration evaluates 2 × 25 solutions.  Stryczek's paper does not use CS, so
no budget is given; the default 5,000 solutions equals CRIPSO's and the GA's.
Every new position is snapped onto the register grid inside the bounds (the
program clips to the bounds); fixed registers never move.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from setupfix.optimize._base import Evaluator, Metaheuristic
from setupfix.optimize._problem import CorrectionProblem

__all__ = ["CuckooSearch", "mantegna_sigma", "levy_steps"]

Array = npt.NDArray[np.float64]


def mantegna_sigma(beta: float) -> float:
    """σ_u of Mantegna's algorithm for a Lévy-stable step of index β (0.6966 for β = 1.5)."""
    num = math.gamma(1.0 + beta) * math.sin(math.pi * beta / 2.0)
    den = math.gamma((1.0 + beta) / 2.0) * beta * 2.0 ** ((beta - 1.0) / 2.0)
    return (num / den) ** (1.0 / beta)


def levy_steps(shape: tuple[int, ...], beta: float, rng: np.random.Generator) -> Array:
    """Lévy-flight steps u / |v|^(1/β) by Mantegna (1994), component-wise, of the given shape."""
    u = rng.normal(0.0, mantegna_sigma(beta), size=shape)
    v = rng.normal(0.0, 1.0, size=shape)
    return u / np.abs(v) ** (1.0 / beta)


def greedy(x: Array, f: Array, x_new: Array, f_new: Array) -> tuple[Array, Array]:
    """Keep each new solution that is at least as good as the nest it came from (row-wise)."""
    take = f_new >= f
    return np.where(take[:, None], x_new, x), np.where(take, f_new, f)


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

    def __init__(self, *, n_nests: int = 25, pa: float = 0.25, alpha: float = 0.01, beta: float = 1.5,
                 n_solutions: int = 5_000, seed: int | None = None) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_nests = n_nests
        self.pa = pa
        self.alpha = alpha
        self.beta = beta

    def _evaluate_some(self, evaluate: Evaluator, x: Array, f: Array, x_new: Array) -> tuple[Array, Array]:
        """Evaluate as many new rows as the budget allows and apply the greedy choice to them."""
        m = min(x.shape[0], evaluate.remaining)
        f_new = evaluate(x_new[:m])
        head_x, head_f = greedy(x[:m], f[:m], x_new[:m], f_new)
        return np.vstack([head_x, x[m:]]), np.concatenate([head_f, f[m:]])

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        n = problem.n_registers
        k = max(1, min(self.n_nests, evaluate.remaining))
        nests = problem.sample(rng, k)
        f = evaluate(nests)
        while evaluate.remaining > 0:
            best = nests[int(np.argmax(f))]
            # 1. Lévy flights, scaled by the distance to the best nest
            step = self.alpha * levy_steps((k, n), self.beta, rng) * (nests - best)
            cuckoos = problem.snap(nests + step * rng.normal(size=(k, n)))
            nests, f = self._evaluate_some(evaluate, nests, f, cuckoos)
            if evaluate.remaining <= 0:
                break
            # 2. discovery: coordinates move with probability 1 − pa along a random difference
            moving = rng.random((k, n)) > self.pa
            diff = nests[rng.permutation(k)] - nests[rng.permutation(k)]
            fresh = problem.snap(nests + rng.random() * diff * moving)
            nests, f = self._evaluate_some(evaluate, nests, f, fresh)
