"""Two genetic algorithms: the elitist (μ + λ) GA of Stryczek's comparison and Wang's float GA.

:func:`tournament_ga` — Stryczek (2014): population 50, gene mutation probability
0.1, elitism ("the winners of the competition qualify to the next population").
The 2009 flow chart is not available, so the operators are the textbook ones for
real genes: binary tournaments (parents drawn with replacement); intermediate
recombination child = a ⊙ p1 + (1 − a) ⊙ p2, a ~ U(0, 1) per gene (Mühlenbein &
Schlierkamp-Voosen 1993); each gene redrawn uniformly in its bounds with
probability 0.1; (μ + λ) survival, so the best point is never lost.

:func:`roulette_ga` — Wang et al. (2017) §3.4: floating-point encoding, roulette
selection, arithmetic crossover (eq. 14) with probability 0.7, Gaussian mutation
(eq. 15) with probability 0.02, the best individual carried over.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.search.space import Array, Objective, Observer, SearchResult, Space, launch

__all__ = ["tournament_ga", "roulette_ga", "tournament", "recombine", "mutate", "survive"]


def tournament(values: Array, n: int, rng: np.random.Generator, size: int = 2) -> npt.NDArray[np.int64]:
    """Indices of n winners (smallest value) of tournaments among ``size`` random individuals.

    values : ndarray of shape (μ,) → ndarray of shape (n,)
    """
    entrants = rng.integers(0, values.size, size=(n, size))
    winners: npt.NDArray[np.int64] = entrants[np.arange(n), np.argmin(values[entrants], axis=1)]
    return winners


def recombine(p1: Array, p2: Array, rng: np.random.Generator) -> Array:
    """Intermediate recombination a ⊙ p1 + (1 − a) ⊙ p2, a ~ U(0, 1) per gene; shapes (λ, n)."""
    a = rng.random(p1.shape)
    return a * p1 + (1.0 - a) * p2


def mutate(children: Array, lb: Array, ub: Array, rate: float, rng: np.random.Generator) -> Array:
    """Redraw each gene with probability ``rate`` uniformly in [lb, ub]; children of shape (λ, n)."""
    hit = rng.random(children.shape) < rate
    fresh = rng.uniform(lb, ub, size=children.shape)
    return np.where(hit, fresh, children)


def survive(x: Array, values: Array, mu: int) -> tuple[Array, Array]:
    """(μ + λ) survival: the μ best (smallest values) of parents and children, best first, stable on ties."""
    keep = np.argsort(values, kind="stable")[:mu]
    return x[keep], values[keep]


def tournament_ga(
    objective: Objective,
    space: Space,
    *,
    budget: int,
    rng: np.random.Generator,
    population: int = 50,
    mutation_rate: float = 0.1,
    tournament_size: int = 2,
    x0: npt.ArrayLike | None = None,
    observe: Observer | None = None,
) -> SearchResult:
    """Minimise ``objective`` over ``space`` by the elitist (μ + λ) GA, λ = μ = ``population``.

    Returns
    -------
    SearchResult
        History: best value after the start population and after each generation.
    """
    tally, x, f = launch("genetic algorithm", objective, space, rng, budget, population, x0, observe)
    mu = len(x)
    history = [float(f.min())]
    while tally.remaining > 0:
        lam = min(int(population), tally.remaining)
        i = tournament(f, lam, rng, tournament_size)
        j = tournament(f, lam, rng, tournament_size)
        children = space.project(mutate(recombine(x[i], x[j], rng), space.lower, space.upper, mutation_rate, rng))
        x, f = survive(np.vstack([x, children]), np.concatenate([f, tally(children)]), mu)
        history.append(float(f[0]))
    return SearchResult(x[0].copy(), float(f[0]), np.asarray(history), tally.count)


def roulette_ga(
    objective: Objective,
    space: Space,
    *,
    budget: int,
    rng: np.random.Generator,
    pop_size: int = 40,
    p_crossover: float = 0.7,
    p_mutation: float = 0.02,
    mutation_scale: float = 0.1,
    x0: npt.ArrayLike | None = None,
    observe: Observer | None = None,
) -> SearchResult:
    """Minimise ``objective`` over ``space`` with the floating-point GA of Wang et al. (2017), §3.4.

    Each generation: roulette selection on a windowed fitness (worst − F; plain 1/F
    makes the wheel almost uniform once all values are close), arithmetic crossover
    of consecutive pairs with probability ``p_crossover`` (eq. 14), Gaussian mutation
    of single genes with probability ``p_mutation`` and standard deviation
    ``mutation_scale`` × range (eq. 15; a gene leaving the space is drawn again, up
    to 20 times, then projected), the best individual carried over unchanged.

    Returns
    -------
    SearchResult
        History: best value after the start population and after each generation.
    """
    tally, pop, fit = launch("genetic algorithm", objective, space, rng, budget, pop_size, x0, observe)
    size = len(pop)
    lo, hi = space.lower, space.upper
    best = int(np.argmin(fit))
    elite, elite_f = pop[best].copy(), float(fit[best])
    history = [elite_f]
    beta = mutation_scale * (hi - lo)
    while tally.remaining > 0:
        finite = np.isfinite(fit)
        worst = fit[finite].max() if finite.any() else 1.0
        weight = np.where(finite, worst - fit, 0.0) + 1e-12 * (1.0 + abs(worst))
        parents = pop[rng.choice(size, size=size, p=weight / weight.sum())]
        children = parents.copy()
        n_pairs = size // 2
        cross = rng.random(n_pairs) < p_crossover
        sig = rng.random((n_pairs, 1))
        a, b = parents[0 : 2 * n_pairs : 2], parents[1 : 2 * n_pairs : 2]
        children[0 : 2 * n_pairs : 2] = np.where(cross[:, None], sig * a + (1 - sig) * b, a)
        children[1 : 2 * n_pairs : 2] = np.where(cross[:, None], (1 - sig) * a + sig * b, b)
        mask = rng.random(children.shape) < p_mutation
        trial = children + beta * rng.normal(size=children.shape)
        for _retry in range(20):
            bad = mask & ((trial < lo) | (trial > hi))
            if not bad.any():
                break
            trial = np.where(bad, children + beta * rng.normal(size=children.shape), trial)
        children = np.where(mask, space.project(trial), children)
        children[0] = elite  # elitism
        m = min(size, tally.remaining)
        pop, fit = children[:m], tally(children[:m])
        if m < size:  # the budget ends inside a generation
            pop, fit = np.vstack([pop, children[m:]]), np.concatenate([fit, np.full(size - m, np.inf)])
        best = int(np.argmin(fit))
        if fit[best] <= elite_f:
            elite, elite_f = pop[best].copy(), float(fit[best])
        history.append(elite_f)
    return SearchResult(elite, elite_f, np.asarray(history), tally.count)
