"""Coral reefs inspired particle swarm optimisation (CRIPSO), Stryczek (2014).

draft
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.objective import F1_WEIGHT
from setupfix.optimize._base import Evaluator, Metaheuristic
from setupfix.optimize._problem import CorrectionProblem

__all__ = ["CRIPSO", "coefficient_schedule", "planula_position"]

Array = npt.NDArray[np.float64]


def coefficient_schedule(n_solutions: int) -> Array:
    """c1 = c2 = cos(π/2 · L_i / L) for L_i = 1 … L (eq. 11)."""
    L = int(n_solutions)
    return np.cos(0.5 * np.pi * np.arange(1, L + 1) / L)


def planula_position(x: Array, plast: Array, pbest: Array, gbest: Array, *, inertia: float,
                     c1: Array | float, c2: Array | float, r1: Array, r2: Array) -> Array:
    """Eq. 1 (continuous, before snapping)."""
    return x + inertia * (plast - x) + c1 * r1 * (pbest - x) + c2 * r2 * (gbest - x)


class CRIPSO(Metaheuristic):
    name: ClassVar[str] = "cripso"

    def __init__(self, *, n_polyps: int = 100, n_solutions: int = 5000, inertia: float = 0.75,
                 seed: int | None = None) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_polyps = n_polyps
        self.inertia = inertia

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        L = evaluate.remaining
        P = min(int(self.n_polyps), L)
        n = problem.n_registers
        h = problem.resolution
        kmin = problem.kmin.astype(float)
        kmax = problem.kmax.astype(float)
        # margins = B + k @ Ak (grid units k): min(dev - lower, upper - dev) + h k [C, -C]
        Ak = h * np.hstack([problem.composite, -problem.composite])
        B = np.concatenate([problem.deviation - problem.lower, problem.upper - problem.deviation])
        w_in = float(self.inertia)

        S = np.empty((L, n))
        S[:P] = rng.integers(problem.kmin, problem.kmax + 1, size=(P, n))
        f0 = F1_WEIGHT * np.min(B + S[:P] @ Ak, axis=1) - h * np.sqrt(np.einsum("ij,ij->i", S[:P], S[:P]))
        F = f0.tolist()
        pos = list(range(P))
        pb = list(range(P))
        fpb = list(F)
        V = np.zeros((P, n))
        gi = int(np.argmax(f0))
        gf = F[gi]

        steps = L - P
        first = rng.integers(0, P, steps) if steps else np.zeros(0, int)
        second = (first + rng.integers(1, P, steps)) % P if (steps and P > 1) else first
        r = rng.random((2, steps, n))
        c = coefficient_schedule(L)[P:]
        CR1 = c[:, None] * r[0]
        CR2 = c[:, None] * r[1]
        A0 = 1.0 - CR1 - CR2
        sqrt = math.sqrt
        for t, (i, j) in enumerate(zip(first.tolist(), second.tolist())):
            s = P + t
            if F[i] >= F[j]:
                win, lose = i, j
            else:
                win, lose = j, i
            x = S[pos[win]]
            new = S[s]
            np.multiply(A0[t], x, out=new)
            new += CR1[t] * S[pb[win]]
            new += CR2[t] * S[gi]
            new += w_in * V[win]
            np.rint(new, out=new)
            np.maximum(new, kmin, out=new)
            np.minimum(new, kmax, out=new)
            d = new - x
            V[win] = d
            V[lose] = d
            f = F1_WEIGHT * (B + new @ Ak).min() - h * sqrt(new @ new)
            pos[lose] = s
            F[lose] = f
            if f > fpb[win]:
                pb[win] = s
                fpb[win] = f
            pb[lose] = pb[win]
            fpb[lose] = fpb[win]
            if f > gf:
                gi = s
                gf = f
        X = S * h
        evaluate(X)
