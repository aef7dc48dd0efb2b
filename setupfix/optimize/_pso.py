"""Classic particle swarm optimisation, asynchronous form, as Stryczek (2014) compares it.

Kennedy & Eberhart (1995) in the inertia form of Poli et al. (2007):

    v_i ← w·v_i + c1·r1 ⊙ (pbest_i − x_i) + c2·r2 ⊙ (gbest − x_i)
    x_i ← x_i + v_i

Stryczek's settings ("Comparison…" section): 100 particles, 10,000 solutions,
c1 = c2 = cos(π/2 · L_i / L) (eq. 11, L_i the running number of the solution, L the
budget) and the global best "updated each time after generating a new solution",
i.e. the asynchronous PSO in which particle i already steers towards a gbest that
particle i − 1 improved in the same sweep.  The inertia of the classic PSO is not
printed; w = 0.75, the value the paper gives for CRIPSO, is used (a keyword).

Speed without changing the algorithm
-------------------------------------
A sweep's random numbers r1, r2 are drawn up front.  All remaining particles of
the sweep are then moved and evaluated as one numpy block *speculatively*, under
the current gbest; the first particle that improves gbest is accepted with every
particle before it, and the block is recomputed from the next particle with the
new gbest.  Particles after an improvement never see a stale gbest, so the
trajectory is identical to the particle-by-particle loop with the same random
numbers (tests check this against a plain loop).  Only accepted solutions are
counted as evaluated; the discarded speculative rows are a computing device.

Decisions on the register grid
------------------------------
Positions are grid points inside the bounds (``problem.snap`` after every move);
velocities stay continuous and are clamped to ±v_max = ``vmax_fraction`` · (ub − lb).
Fixed registers (lb = ub = 0) never move.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.optimize._base import Evaluator, Metaheuristic
from setupfix.optimize._problem import CorrectionProblem

__all__ = ["PSO", "acceleration"]

Array = npt.NDArray[np.float64]


def acceleration(solution_number: npt.ArrayLike, budget: int) -> Array:
    """Cognition and social coefficients c1 = c2 = cos(π/2 · L_i / L) (Stryczek 2014, eq. 11).

    Parameters
    ----------
    solution_number : ndarray of shape (m,)
        Running number L_i (1-based) of the solution each particle is about to generate.
    budget : int
        Total number of solutions L.

    Returns
    -------
    ndarray of shape (m,), values in [0, 1]
    """
    ratio = np.minimum(np.asarray(solution_number, dtype=float) / float(budget), 1.0)
    return np.cos(0.5 * np.pi * ratio)


def move(x: Array, v: Array, pbest: Array, gbest: Array, c: Array, r1: Array, r2: Array,
         w: float, vmax: Array) -> Array:
    """New velocities of a block of particles (inertia PSO, Poli et al. 2007).

    Parameters
    ----------
    x, v, pbest : ndarray of shape (m, n) [model unit]
        Positions, velocities and personal bests of m particles.
    gbest : ndarray of shape (n,) [model unit]
    c : ndarray of shape (m,)
        c1 = c2 of each particle (eq. 11).
    r1, r2 : ndarray of shape (m, n)
        Uniform random numbers in [0, 1).
    w : float
        Inertia weight.
    vmax : ndarray of shape (n,) [model unit]
        Velocity clamp per register (0 for fixed registers).

    Returns
    -------
    ndarray of shape (m, n) [model unit]
    """
    cc = c[:, None]
    v_new = w * v + cc * r1 * (pbest - x) + cc * r2 * (gbest - x)
    return np.clip(v_new, -vmax, vmax)


class PSO(Metaheuristic):
    """Asynchronous classic PSO on the register grid (Stryczek 2014 comparison).

    Parameters
    ----------
    n_particles : int, default=100
    n_solutions : int, default=10_000
        Solutions evaluated, the initial swarm included.
    inertia : float, default=0.75
    vmax_fraction : float, default=0.2
        Velocity clamp as a fraction of each register's range.
    seed : int, optional
    """

    name = "pso"

    def __init__(self, *, n_particles: int = 100, n_solutions: int = 10_000, inertia: float = 0.75,
                 vmax_fraction: float = 0.2, seed: int | None = None) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_particles = n_particles
        self.inertia = inertia
        self.vmax_fraction = vmax_fraction

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        n = problem.n_registers
        p = max(1, min(self.n_particles, evaluate.remaining))
        vmax = self.vmax_fraction * (problem.ub - problem.lb)
        x = problem.sample(rng, p)
        v = rng.uniform(-1.0, 1.0, size=(p, n)) * vmax
        f = evaluate(x)
        pbest, pbest_f = x.copy(), f.copy()
        g = int(np.argmax(f))
        gbest, gbest_f = x[g].copy(), float(f[g])
        budget = evaluate.budget
        while evaluate.remaining > 0:
            m = min(p, evaluate.remaining)
            r1 = rng.random((m, n))
            r2 = rng.random((m, n))
            number = evaluate.count + 1 + np.arange(m)  # L_i of each particle's new solution
            c = acceleration(number, budget)
            s = 0
            while s < m:
                # Speculative block s..m-1 under the current gbest (see module docstring).
                v_new = move(x[s:m], v[s:m], pbest[s:m], gbest, c[s:m], r1[s:m], r2[s:m], self.inertia, vmax)
                x_new = problem.snap(x[s:m] + v_new)
                _, _, f_new = problem.evaluate(x_new)
                better = np.flatnonzero(f_new > gbest_f)
                stop = int(better[0]) + 1 if better.size else m - s  # rows accepted
                evaluate(x_new[:stop])
                rows = slice(s, s + stop)
                x[rows], v[rows] = x_new[:stop], v_new[:stop]
                own = f_new[:stop] > pbest_f[rows]
                pbest[rows][own] = x_new[:stop][own]
                pbest_f[rows] = np.where(own, f_new[:stop], pbest_f[rows])
                if better.size:
                    gbest, gbest_f = x_new[stop - 1].copy(), float(f_new[stop - 1])
                s += stop
