"""Population searches used to calibrate the thermal models: CS, PSO and a float GA.

All three minimise a *vectorised* objective ``f(pop) -> values`` with ``pop`` of shape
``(P, D)`` inside a box ``[lower, upper]``, draw every random number from the
:class:`numpy.random.Generator` given (or seeded by a fixed default: no unseeded
run), and return a
:class:`SearchResult`.  The searches themselves are the ones of
:mod:`setupfix.search` (shared with the setup-correction optimisers) run on a
:class:`~setupfix.search.Box`; these functions only state the papers' settings and
turn iteration counts into budgets.

* :func:`cuckoo_search` — Yang & Deb (2009) with Mantegna Lévy steps, as used by
  Abdulshahed et al. (2017) (25 nests, pa = 0.25, 100 iterations; Table II).
* :func:`particle_swarm` — inertia PSO, w 0.9 → 0.4, c1 = c2 = 2 (Table II).
* :func:`genetic_algorithm` — Wang et al. (2017) §3.4: floating-point encoding,
  roulette selection, arithmetic crossover eq. (14), Gaussian mutation eq. (15),
  crossover probability 0.7, mutation probability 0.02.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from setupfix.search import Box, SearchResult, generator, mantegna_sigma, roulette_ga
from setupfix.search import cuckoo_search as _cs
from setupfix.search import particle_swarm as _pso

__all__ = ["SearchResult", "cuckoo_search", "particle_swarm", "genetic_algorithm", "mantegna_sigma"]

Array = npt.NDArray[np.float64]
Objective = Callable[[Array], Array]


def cuckoo_search(
    objective: Objective,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    *,
    rng: np.random.Generator | int | None = None,
    n_nests: int = 25,
    pa: float = 0.25,
    n_iter: int = 100,
    alpha: float = 0.01,
    beta: float = 1.5,
    x0: npt.ArrayLike | None = None,
) -> SearchResult:
    """Minimise ``objective`` by cuckoo search with Lévy flights (Yang & Deb 2009).

    Abdulshahed (2017), Algorithm 1; see :func:`setupfix.search.cuckoo_search`.
    2 × ``n_nests`` evaluations per iteration.

    Parameters
    ----------
    objective : callable
        ``(P, D) -> (P,)``, to be minimised.
    lower, upper : array_like, shape (D,)
        Box bounds; every candidate is clipped into it.
    rng : numpy.random.Generator or int, optional
        The only source of randomness, or its seed; None: seed
        :data:`setupfix.search.DEFAULT_SEED` (never an unseeded run).
    n_nests, pa, n_iter : int, float, int
        Paper values 25, 0.25, 100.
    alpha : float
        Step scale (1/100 of the typical length scale, Yang 2010).
    beta : float
        Lévy index λ of the step-length distribution.
    x0 : array_like, shape (D,), optional
        A starting point placed in the first nest (e.g. the least-squares solution).

    Returns
    -------
    SearchResult
        History: best value after the start nests and after each of the ``n_iter`` iterations.
    """
    return _cs(
        objective,
        Box.of(lower, upper),
        budget=n_nests * (1 + 2 * n_iter),
        rng=generator(rng),
        n_nests=n_nests,
        pa=pa,
        alpha=alpha,
        beta=beta,
        x0=x0,
    )


def particle_swarm(
    objective: Objective,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    *,
    rng: np.random.Generator | int | None = None,
    n_particles: int = 25,
    n_iter: int = 100,
    w_start: float = 0.9,
    w_end: float = 0.4,
    c1: float = 2.0,
    c2: float = 2.0,
    v_max: float = 0.2,
    x0: npt.ArrayLike | None = None,
) -> SearchResult:
    """Minimise ``objective`` by synchronous inertia-weight particle swarm optimisation.

    ``v ← w v + c1 r1 ⊙ (pbest − x) + c2 r2 ⊙ (gbest − x); x ← x + v`` with the inertia
    ``w`` falling linearly from ``w_start`` to ``w_end`` (Abdulshahed 2017, Table II);
    see :func:`setupfix.search.particle_swarm`.

    Parameters
    ----------
    objective : callable ``(P, D) -> (P,)``
    lower, upper : array_like, shape (D,)
    rng : numpy.random.Generator or int, optional
        The only source of randomness, or its seed; None: seed
        :data:`setupfix.search.DEFAULT_SEED` (never an unseeded run).
    n_particles, n_iter : int
        Paper values 25 and 100 (one evaluation per particle and iteration).
    w_start, w_end, c1, c2 : float
        Paper values 0.9, 0.4, 2, 2.
    v_max : float
        Velocity clamp as a fraction of the box width.  With c1 = c2 = 2 and no
        constriction the velocities grow without bound; clamping is the usual remedy
        of the inertia-weight PSO this paper uses.  Start velocities are uniform in
        ±v_max / 2 of the width.
    x0 : array_like, shape (D,), optional
        A starting point given to the first particle.

    Returns
    -------
    SearchResult
    """
    return _pso(
        objective,
        Box.of(lower, upper),
        budget=n_particles * (1 + n_iter),
        rng=generator(rng),
        n_particles=n_particles,
        inertia=(w_start, w_end),
        coefficients=(c1, c2),
        v_max=v_max,
        v_init=0.5,
        asynchronous=False,
        x0=x0,
    )


def genetic_algorithm(
    objective: Objective,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    *,
    rng: np.random.Generator | int | None = None,
    pop_size: int = 40,
    n_gen: int = 60,
    p_crossover: float = 0.7,
    p_mutation: float = 0.02,
    mutation_scale: float = 0.1,
    x0: npt.ArrayLike | None = None,
) -> SearchResult:
    """Minimise ``objective`` with the floating-point GA of Wang et al. (2017), §3.4.

    Roulette selection, arithmetic crossover (eq. 14), Gaussian mutation (eq. 15),
    the best individual carried over; see :func:`setupfix.search.roulette_ga`.

    Parameters
    ----------
    objective : callable ``(P, D) -> (P,)``
    lower, upper : array_like, shape (D,)
    rng : numpy.random.Generator or int, optional
        The only source of randomness, or its seed; None: seed
        :data:`setupfix.search.DEFAULT_SEED` (never an unseeded run).
    pop_size, n_gen : int
    p_crossover, p_mutation : float
        Paper values 0.7 and 0.02.
    mutation_scale : float
        β of eq. (15) as a fraction of each gene's range.
    x0 : array_like, shape (D,), optional
        An individual seeded into the first population.

    Returns
    -------
    SearchResult
    """
    return roulette_ga(
        objective,
        Box.of(lower, upper),
        budget=pop_size * (1 + n_gen),
        rng=generator(rng),
        pop_size=pop_size,
        p_crossover=p_crossover,
        p_mutation=p_mutation,
        mutation_scale=mutation_scale,
        x0=x0,
    )
