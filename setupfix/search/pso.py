"""Inertia particle swarm optimisation, synchronous or asynchronous.

Kennedy & Eberhart (1995) in the inertia form of Poli et al. (2007):

    v_i ← w·v_i + c1·r1 ⊙ (pbest_i − x_i) + c2·r2 ⊙ (gbest − x_i),  |v_i| ≤ v_max
    x_i ← project(x_i + v_i)

* **Asynchronous** (Stryczek 2014, classic PSO of the comparison): the global best
  is "updated each time after generating a new solution", so particle i already
  steers towards a gbest that particle i − 1 improved in the same sweep;
  c1 = c2 = cos(π/2 · L_i / L) (eq. 11, :func:`acceleration`), w constant.
* **Synchronous** (Abdulshahed et al. 2017, Table II): gbest is updated after the
  sweep; c1 = c2 = 2, w falling linearly from 0.9 to 0.4 over the sweeps.

Speed without changing the asynchronous algorithm: a sweep's r1, r2 are drawn up
front; all remaining particles of the sweep are moved and evaluated as one numpy
block *speculatively* under the current gbest; the first particle that improves
gbest is accepted with every particle before it, and the block is recomputed from
the next particle with the new gbest.  Particles after an improvement never see a
stale gbest, so the trajectory is identical to the particle-by-particle loop with
the same random numbers (tests check this).  Only accepted points are counted as
evaluated; the discarded speculative rows are a computing device.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.search.space import Array, Objective, Observer, SearchResult, Space, launch

__all__ = ["particle_swarm", "acceleration", "velocity"]


def acceleration(solution_number: npt.ArrayLike, budget: int) -> Array:
    """Cognition and social coefficients c1 = c2 = cos(π/2 · L_i / L) (Stryczek 2014, eq. 11).

    Parameters
    ----------
    solution_number : ndarray of shape (m,)
        Running number L_i (1-based) of the solution each particle (or planula) is
        about to generate.
    budget : int
        Total number of solutions L.

    Returns
    -------
    ndarray of shape (m,), values in [0, 1]: from almost 1 down to 0 at L_i = L.
    """
    ratio = np.minimum(np.asarray(solution_number, dtype=float) / float(budget), 1.0)
    return np.cos(0.5 * np.pi * ratio)


def velocity(
    x: Array, v: Array, pbest: Array, gbest: Array, c1: Array, c2: Array, r1: Array, r2: Array, w: float, vmax: Array
) -> Array:
    """New velocities of a block of particles (inertia PSO, Poli et al. 2007).

    Parameters
    ----------
    x, v, pbest : ndarray of shape (m, n)
        Positions, velocities and personal bests of m particles.
    gbest : ndarray of shape (n,)
    c1, c2 : ndarray of shape (m, 1)
        Cognition and social coefficient of each particle.
    r1, r2 : ndarray of shape (m, n)
        U(0, 1) numbers.
    w : float
        Inertia weight.
    vmax : ndarray of shape (n,)
        Velocity clamp per coordinate.

    Returns
    -------
    ndarray of shape (m, n)
    """
    return np.clip(w * v + c1 * r1 * (pbest - x) + c2 * r2 * (gbest - x), -vmax, vmax)


def particle_swarm(
    objective: Objective,
    space: Space,
    *,
    budget: int,
    rng: np.random.Generator,
    n_particles: int = 25,
    inertia: tuple[float, float] = (0.9, 0.4),
    coefficients: tuple[float, float] | None = (2.0, 2.0),
    v_max: float = 0.2,
    v_init: float = 0.5,
    asynchronous: bool = False,
    x0: npt.ArrayLike | None = None,
    observe: Observer | None = None,
) -> SearchResult:
    """Minimise ``objective`` over ``space`` by inertia PSO.

    Parameters
    ----------
    objective : callable, (m, n) → (m,)
    space : Space
    budget : int
        Points evaluated at most, the start swarm included.
    rng : numpy.random.Generator
    n_particles : int
    inertia : (float, float)
        w at the first and at the last sweep, linear in between (equal: constant).
    coefficients : (float, float) or None
        Constant (c1, c2); ``None``: c1 = c2 = eq. 11 of the solution number.
    v_max : float
        Velocity clamp as a fraction of each coordinate's range.
    v_init : float
        Start velocities uniform in ±``v_init`` · v_max · range.
    asynchronous : bool
        Update gbest after every point (True) or after every sweep (False).
    x0 : array_like of shape (n,), optional
        Start point of the first particle.
    observe : callable, optional
        Shown every block of points counted as evaluated.

    Returns
    -------
    SearchResult
        History: best value after the start swarm and after each sweep.
    """
    vmax = v_max * (space.upper - space.lower)
    tally, x, f = launch("particle swarm", objective, space, rng, budget, n_particles, x0, observe)
    p, n = x.shape
    v = rng.uniform(-v_init, v_init, size=(p, n)) * vmax
    pbest, pbest_f = x.copy(), f.copy()
    g = int(np.argmin(f))
    gbest, gbest_f = x[g].copy(), float(f[g])
    history = [gbest_f]
    sweeps = max(-(-(tally.budget - p) // p) - 1, 1)
    sweep = 0
    while tally.remaining > 0:
        w = inertia[0] - (inertia[0] - inertia[1]) * sweep / sweeps
        m = min(p, tally.remaining)
        r1 = rng.random((m, n))
        r2 = rng.random((m, n))
        if coefficients is None:
            c1 = c2 = acceleration(tally.count + 1 + np.arange(m), tally.budget)[:, None]
        else:
            c1, c2 = np.full((m, 1), coefficients[0]), np.full((m, 1), coefficients[1])
        s = 0
        while s < m:
            v_new = velocity(x[s:m], v[s:m], pbest[s:m], gbest, c1[s:m], c2[s:m], r1[s:m], r2[s:m], w, vmax)
            x_new = space.project(x[s:m] + v_new)
            f_new = tally.peek(x_new)
            better = np.flatnonzero(f_new < gbest_f) if asynchronous else np.empty(0, dtype=np.int64)
            stop = int(better[0]) + 1 if better.size else m - s  # rows accepted
            tally.accept(x_new[:stop], f_new[:stop])
            rows = slice(s, s + stop)
            x[rows], v[rows] = x_new[:stop], v_new[:stop]
            own = f_new[:stop] < pbest_f[rows]
            pbest[rows][own] = x_new[:stop][own]
            pbest_f[rows] = np.where(own, f_new[:stop], pbest_f[rows])
            if better.size:
                gbest, gbest_f = x_new[stop - 1].copy(), float(f_new[stop - 1])
            s += stop
        if not asynchronous:
            g = int(np.argmin(pbest_f))
            gbest, gbest_f = pbest[g].copy(), float(pbest_f[g])
        history.append(gbest_f)
        sweep += 1
    return SearchResult(gbest, gbest_f, np.asarray(history), tally.count)
