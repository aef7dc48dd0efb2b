"""Cuckoo search (CS) of Yang & Deb (2009) with Mantegna's Lévy flights.

One iteration (Yang & Deb 2009; Yang's reference program of 2009/2014; Abdulshahed
et al. 2017, Algorithm 1):

1. every nest s lays a cuckoo egg by a Lévy flight scaled to its distance from the
   best nest:  s' = s + α · L ⊙ (s − best) ⊙ N(0, 1),  α = 0.01, where L is a Lévy
   step by Mantegna's algorithm (1994), β = 1.5:
       σ_u = [Γ(1+β) sin(πβ/2) / (Γ((1+β)/2) β 2^((β−1)/2))]^(1/β),
       L = u / |v|^(1/β),  u ~ N(0, σ_u²),  v ~ N(0, 1);
   the egg replaces its nest when it is not worse (greedy), so the best nest
   never moves;
2. discovery: each coordinate moves with probability 1 − p_a by one common
   U(0, 1) times the difference of two randomly permuted nests (the reference
   program's "empty nests" step), again greedily.

2 × ``n_nests`` evaluations per iteration; every move is projected into the space.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from setupfix.search.space import Array, Objective, Observer, SearchResult, Space, Tally, launch

__all__ = ["cuckoo_search", "levy_steps", "mantegna_sigma", "greedy"]


def mantegna_sigma(beta: float) -> float:
    """σ_u of Mantegna's algorithm for a Lévy-stable step of index β (0.6966 for β = 1.5)."""
    num = math.gamma(1.0 + beta) * math.sin(math.pi * beta / 2.0)
    den = math.gamma((1.0 + beta) / 2.0) * beta * 2.0 ** ((beta - 1.0) / 2.0)
    return float((num / den) ** (1.0 / beta))


def levy_steps(shape: tuple[int, ...], beta: float, rng: np.random.Generator) -> Array:
    """Lévy-flight steps u / |v|^(1/β) by Mantegna (1994), component-wise, of the given shape."""
    u = rng.normal(0.0, mantegna_sigma(beta), size=shape)
    v = rng.normal(0.0, 1.0, size=shape)
    return u / np.abs(v) ** (1.0 / beta)


def greedy(x: Array, f: Array, x_new: Array, f_new: Array) -> tuple[Array, Array]:
    """Keep each new point that is not worse (smaller or equal value) than the one it came from."""
    take = f_new <= f
    return np.where(take[:, None], x_new, x), np.where(take, f_new, f)


def _replace(tally: Tally, x: Array, f: Array, x_new: Array) -> tuple[Array, Array]:
    """Evaluate as many new rows as the budget allows and apply the greedy choice to them."""
    m = min(x.shape[0], tally.remaining)
    head_x, head_f = greedy(x[:m], f[:m], x_new[:m], tally(x_new[:m]))
    return np.vstack([head_x, x[m:]]), np.concatenate([head_f, f[m:]])


def cuckoo_search(
    objective: Objective,
    space: Space,
    *,
    budget: int,
    rng: np.random.Generator,
    n_nests: int = 25,
    pa: float = 0.25,
    alpha: float = 0.01,
    beta: float = 1.5,
    x0: npt.ArrayLike | None = None,
    observe: Observer | None = None,
) -> SearchResult:
    """Minimise ``objective`` over ``space`` by cuckoo search with Lévy flights.

    Parameters
    ----------
    objective : callable, (m, n) → (m,)
    space : Space
    budget : int
        Points evaluated at most (the start nests included).
    rng : numpy.random.Generator
        The only source of randomness.
    n_nests, pa, alpha, beta :
        Nests, discovery rate p_a, step scale α and Lévy index β (25, 0.25, 0.01, 1.5).
    x0 : array_like of shape (n,), optional
        A start point placed in the first nest.
    observe : callable, optional
        Shown every evaluated block and its values.

    Returns
    -------
    SearchResult
        History: best value after the start nests and after each iteration.
    """
    tally, nests, f = launch("cuckoo search", objective, space, rng, budget, n_nests, x0, observe)
    shape = k, _ = nests.shape
    history = [float(f.min())]
    while tally.remaining > 0:
        best = nests[int(np.argmin(f))]
        step = alpha * levy_steps(shape, beta, rng) * (nests - best)
        nests, f = _replace(tally, nests, f, space.project(nests + step * rng.normal(size=shape)))
        if tally.remaining > 0:
            moving = rng.random(shape) > pa
            diff = nests[rng.permutation(k)] - nests[rng.permutation(k)]
            nests, f = _replace(tally, nests, f, space.project(nests + rng.random() * diff * moving))
        history.append(float(f.min()))
    best_i = int(np.argmin(f))
    return SearchResult(nests[best_i].copy(), float(f[best_i]), np.asarray(history), tally.count)
