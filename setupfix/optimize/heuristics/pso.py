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

The search is :func:`setupfix.search.particle_swarm` in its asynchronous form
(one implementation, shared with the thermal calibration's synchronous PSO; its
speculative-block evaluation keeps the particle-by-particle trajectory), minimising
−f on the register grid.

Decisions on the register grid
------------------------------
Positions are grid points inside the bounds (``problem.snap`` after every move);
velocities stay continuous and are clamped to ±v_max = ``vmax_fraction`` · (ub − lb).
Fixed registers (lb = ub = 0) never move.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from setupfix.core.params import Constraint, Interval
from setupfix.optimize.base import POPULATION, Evaluator, GridObjective, GridSpace, Metaheuristic
from setupfix.optimize.problem import CorrectionProblem
from setupfix.search import acceleration, particle_swarm

__all__ = ["PSO", "acceleration"]


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
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        **Metaheuristic._parameter_constraints,
        "n_particles": POPULATION,
        "inertia": [Interval(float, 0.0, 2.0)],
        "vmax_fraction": [Interval(float, 0.0, 1.0, closed="right")],
    }

    def __init__(
        self,
        *,
        n_particles: int = 100,
        n_solutions: int = 10_000,
        inertia: float = 0.75,
        vmax_fraction: float = 0.2,
        seed: int | None = None,
    ) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_particles = n_particles
        self.inertia = inertia
        self.vmax_fraction = vmax_fraction

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        objective = GridObjective(evaluate)
        particle_swarm(
            objective,
            GridSpace(problem),
            budget=evaluate.remaining,
            rng=rng,
            n_particles=self.n_particles,
            inertia=(self.inertia, self.inertia),
            coefficients=None,
            v_max=self.vmax_fraction,
            v_init=1.0,
            asynchronous=True,
            observe=objective.observe,
        )
