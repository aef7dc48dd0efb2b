"""Population searches used to calibrate the thermal models: CS, PSO and a float GA.

All three minimise a *vectorised* objective ``f(pop) -> values`` with ``pop`` of shape
``(P, D)`` inside a box ``[lower, upper]``, draw every random number from one
:class:`numpy.random.Generator`, and return a :class:`SearchResult`.

They are written here rather than taken from scipy because scipy has none of the
three algorithms the papers prescribe (``differential_evolution`` is another
method), and the research notes (§1) found the third-party libraries either
pinned to old numpy or deviating from the published algorithms.

* :func:`cuckoo_search` — Yang & Deb (2009) with Mantegna Lévy steps, as used by
  Abdulshahed et al. (2017) (25 nests, pa = 0.25, 100 iterations; Table II).
* :func:`particle_swarm` — inertia PSO, w 0.9 → 0.4, c1 = c2 = 2 (Table II).
* :func:`genetic_algorithm` — Wang et al. (2017) §3.4: floating-point encoding,
  roulette selection, arithmetic crossover eq. (14), Gaussian mutation eq. (15),
  crossover probability 0.7, mutation probability 0.02.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize._cs import levy_steps, mantegna_sigma  # one Mantegna implementation

__all__ = ["SearchResult", "cuckoo_search", "particle_swarm", "genetic_algorithm", "mantegna_sigma"]

Array = npt.NDArray[np.float64]
Objective = Callable[[Array], Array]


@dataclass(frozen=True)
class SearchResult:
    """Best point found by a population search.

    Attributes
    ----------
    x : ndarray, shape (D,)
    fun : float
        Objective value at ``x``.
    history : ndarray, shape (iterations + 1,)
        Best-so-far objective after initialisation and after each iteration.
    n_evaluations : int
    """

    x: Array
    fun: float
    history: Array
    n_evaluations: int


def _box(lower: npt.ArrayLike, upper: npt.ArrayLike) -> tuple[Array, Array]:
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    if lo.shape != hi.shape or lo.ndim != 1 or np.any(hi < lo):
        raise ValueError("lower and upper must be 1-D of equal length with lower <= upper")
    return lo, hi


def _safe(values: Array) -> Array:
    # A diverging candidate (inf/nan) must lose every comparison, not poison argmin.
    values = np.asarray(values, dtype=float)
    return np.where(np.isfinite(values), values, np.inf)


def _initial(objective: Objective, lo: Array, hi: Array, size: int, rng: np.random.Generator,
             x0: npt.ArrayLike | None) -> tuple[Array, Array]:
    """A uniform random population in the box (``x0`` clipped into row 0) and its objective values."""
    pop = lo + rng.random((size, lo.size)) * (hi - lo)
    if x0 is not None:
        pop[0] = np.clip(np.asarray(x0, dtype=float), lo, hi)
    return pop, _safe(objective(pop))


def cuckoo_search(objective: Objective, lower: npt.ArrayLike, upper: npt.ArrayLike, *, n_nests: int = 25,
                  pa: float = 0.25, n_iter: int = 100, alpha: float = 0.01, beta: float = 1.5,
                  rng: np.random.Generator | None = None, x0: npt.ArrayLike | None = None) -> SearchResult:
    """Minimise ``objective`` by cuckoo search with Lévy flights (Yang & Deb 2009).

    Each iteration (Abdulshahed 2017, Algorithm 1): every nest lays a cuckoo egg by
    a Lévy flight scaled by its distance to the best nest, ``s' = s + α L ⊙ (s − best) ⊙ N(0,1)``;
    an egg replaces its nest when not worse; then a fraction of the components is
    rebuilt by a random difference of two nests (discovery with probability ``pa``),
    again kept only when not worse.  2 × ``n_nests`` evaluations per iteration.

    Parameters
    ----------
    objective : callable
        ``(P, D) -> (P,)``, to be minimised.
    lower, upper : array_like, shape (D,)
        Box bounds; every candidate is clipped into it.
    n_nests, pa, n_iter : int, float, int
        Paper values 25, 0.25, 100.
    alpha : float
        Step scale (1/100 of the typical length scale, Yang 2010).
    beta : float
        Lévy index λ of the step-length distribution.
    rng : numpy.random.Generator
    x0 : array_like, shape (D,), optional
        A starting point placed in the first nest (e.g. the least-squares solution).

    Returns
    -------
    SearchResult
    """
    rng = rng if rng is not None else np.random.default_rng()
    lo, hi = _box(lower, upper)
    dim = lo.size
    nests, fit = _initial(objective, lo, hi, n_nests, rng, x0)
    evaluations = n_nests
    best = int(np.argmin(fit))
    history = [fit[best]]
    for _ in range(n_iter):
        # Lévy flights around each nest, scaled by its distance to the best nest,
        # so the best nest itself does not move (the elitism of the method).
        step = levy_steps((n_nests, dim), beta, rng)
        trial = nests + alpha * step * (nests - nests[best]) * rng.normal(size=(n_nests, dim))
        trial = np.clip(trial, lo, hi)
        f_trial = _safe(objective(trial))
        evaluations += n_nests
        better = f_trial <= fit
        nests[better], fit[better] = trial[better], f_trial[better]
        # Discovery: a component is rebuilt unless the egg is found (probability pa);
        # the move is a random difference of two nests times one scalar step.
        keep = rng.random((n_nests, dim)) > pa
        diff = nests[rng.permutation(n_nests)] - nests[rng.permutation(n_nests)]
        trial = np.clip(nests + rng.random() * diff * keep, lo, hi)
        f_trial = _safe(objective(trial))
        evaluations += n_nests
        better = f_trial <= fit
        nests[better], fit[better] = trial[better], f_trial[better]
        best = int(np.argmin(fit))
        history.append(fit[best])
    return SearchResult(nests[best].copy(), float(fit[best]), np.asarray(history), evaluations)


def particle_swarm(objective: Objective, lower: npt.ArrayLike, upper: npt.ArrayLike, *, n_particles: int = 25,
                   n_iter: int = 100, w_start: float = 0.9, w_end: float = 0.4, c1: float = 2.0, c2: float = 2.0,
                   v_max: float = 0.2, rng: np.random.Generator | None = None,
                   x0: npt.ArrayLike | None = None) -> SearchResult:
    """Minimise ``objective`` by inertia-weight particle swarm optimisation.

    ``v ← w v + c1 r1 ⊙ (pbest − x) + c2 r2 ⊙ (gbest − x); x ← x + v`` with the inertia
    ``w`` falling linearly from ``w_start`` to ``w_end`` (Abdulshahed 2017, Table II).

    Parameters
    ----------
    objective : callable ``(P, D) -> (P,)``
    lower, upper : array_like, shape (D,)
    n_particles, n_iter : int
        Paper values 25 and 100 (one evaluation per particle and iteration).
    w_start, w_end, c1, c2 : float
        Paper values 0.9, 0.4, 2, 2.
    v_max : float
        Velocity clamp as a fraction of the box width.  With c1 = c2 = 2 and no
        constriction the velocities grow without bound; clamping is the usual remedy
        of the inertia-weight PSO this paper uses.
    rng : numpy.random.Generator
    x0 : array_like, shape (D,), optional
        A starting point given to the first particle.

    Returns
    -------
    SearchResult
    """
    rng = rng if rng is not None else np.random.default_rng()
    lo, hi = _box(lower, upper)
    dim = lo.size
    span = hi - lo
    x, fit = _initial(objective, lo, hi, n_particles, rng, x0)
    vel = (rng.random((n_particles, dim)) - 0.5) * span * v_max
    evaluations = n_particles
    pbest, pfit = x.copy(), fit.copy()
    g = int(np.argmin(pfit))
    history = [pfit[g]]
    vlim = v_max * span
    for it in range(n_iter):
        w = w_start - (w_start - w_end) * it / max(n_iter - 1, 1)
        r1 = rng.random((n_particles, dim))
        r2 = rng.random((n_particles, dim))
        vel = w * vel + c1 * r1 * (pbest - x) + c2 * r2 * (pbest[g] - x)
        vel = np.clip(vel, -vlim, vlim)
        x = np.clip(x + vel, lo, hi)
        fit = _safe(objective(x))
        evaluations += n_particles
        better = fit < pfit
        pbest[better], pfit[better] = x[better], fit[better]
        g = int(np.argmin(pfit))
        history.append(pfit[g])
    return SearchResult(pbest[g].copy(), float(pfit[g]), np.asarray(history), evaluations)


def genetic_algorithm(objective: Objective, lower: npt.ArrayLike, upper: npt.ArrayLike, *, pop_size: int = 40,
                      n_gen: int = 60, p_crossover: float = 0.7, p_mutation: float = 0.02,
                      mutation_scale: float = 0.1, rng: np.random.Generator | None = None,
                      x0: npt.ArrayLike | None = None) -> SearchResult:
    """Minimise ``objective`` with the floating-point GA of Wang et al. (2017), §3.4.

    Each generation: roulette selection (smaller objective, larger probability),
    arithmetic crossover of pairs with probability ``p_crossover`` (eq. (14)),
    Gaussian mutation of single genes with probability ``p_mutation`` (eq. (15)),
    a mutated gene outside its bounds being drawn again.  The best individual is
    carried over unchanged ("the best individual is survived").

    Parameters
    ----------
    objective : callable ``(P, D) -> (P,)``
    lower, upper : array_like, shape (D,)
    pop_size, n_gen : int
    p_crossover, p_mutation : float
        Paper values 0.7 and 0.02.
    mutation_scale : float
        β of eq. (15) as a fraction of each gene's range.
    rng : numpy.random.Generator
    x0 : array_like, shape (D,), optional
        An individual seeded into the first population.

    Returns
    -------
    SearchResult
    """
    rng = rng if rng is not None else np.random.default_rng()
    lo, hi = _box(lower, upper)
    dim = lo.size
    pop, fit = _initial(objective, lo, hi, pop_size, rng, x0)
    evaluations = pop_size
    best = int(np.argmin(fit))
    elite, elite_f = pop[best].copy(), fit[best]
    history = [elite_f]
    beta = mutation_scale * (hi - lo)
    for _ in range(n_gen):
        # Roulette on a windowed fitness (worst − F): plain 1/F would make the
        # wheel almost uniform once all objective values are close together.
        finite = np.isfinite(fit)
        worst = fit[finite].max() if finite.any() else 1.0
        weight = np.where(finite, worst - fit, 0.0) + 1e-12 * (1.0 + abs(worst))
        parents = pop[rng.choice(pop_size, size=pop_size, p=weight / weight.sum())]
        # Arithmetic crossover, eq. (14), on consecutive pairs.
        children = parents.copy()
        n_pairs = pop_size // 2
        cross = rng.random(n_pairs) < p_crossover
        sig = rng.random((n_pairs, 1))
        a, b = parents[0:2 * n_pairs:2], parents[1:2 * n_pairs:2]
        ca = np.where(cross[:, None], sig * a + (1 - sig) * b, a)
        cb = np.where(cross[:, None], (1 - sig) * a + sig * b, b)
        children[0:2 * n_pairs:2], children[1:2 * n_pairs:2] = ca, cb
        # Gaussian mutation, eq. (15); redraw the genes that leave the box.
        mask = rng.random((pop_size, dim)) < p_mutation
        trial = children + beta * rng.normal(size=children.shape)
        for _retry in range(20):
            bad = mask & ((trial < lo) | (trial > hi))
            if not bad.any():
                break
            trial = np.where(bad, children + beta * rng.normal(size=children.shape), trial)
        children = np.where(mask, np.clip(trial, lo, hi), children)
        children[0] = elite  # elitism
        pop = children
        fit = _safe(objective(pop))
        evaluations += pop_size
        best = int(np.argmin(fit))
        if fit[best] <= elite_f:
            elite, elite_f = pop[best].copy(), fit[best]
        history.append(elite_f)
    return SearchResult(elite, float(elite_f), np.asarray(history), evaluations)
