"""Search spaces, the budgeted objective every search evaluates through, and the result."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ParameterError

__all__ = ["Space", "Box", "Objective", "Observer", "SearchResult", "Tally", "DEFAULT_SEED", "generator"]

#: Seed used when none is given: every search is reproducible unless asked otherwise.
DEFAULT_SEED = 0

Array = npt.NDArray[np.float64]
#: Vectorised objective to minimise: points of shape (m, n) → values of shape (m,).
Objective = Callable[[Array], Array]
#: Called with every block of points counted as evaluated and their values.
Observer = Callable[[Array, Array], None]


class Space(Protocol):
    """Where a search may go: bounds, uniform start points and the projection of a move."""

    @property
    def lower(self) -> Array: ...

    @property
    def upper(self) -> Array: ...

    def sample(self, rng: np.random.Generator, count: int) -> Array:
        """``count`` points drawn uniformly, shape (count, n)."""
        ...

    def project(self, x: Array) -> Array:
        """The admissible point nearest to each row of ``x`` (clip; snap on a grid)."""
        ...


@dataclass(frozen=True)
class Box:
    """The box [lower, upper] ⊂ ℝⁿ; moves are clipped into it."""

    lower: Array
    upper: Array

    @classmethod
    def of(cls, lower: npt.ArrayLike, upper: npt.ArrayLike) -> Box:
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        if lo.shape != hi.shape or lo.ndim != 1 or not np.all(hi >= lo) or not np.all(np.isfinite(lo + hi)):
            raise ParameterError(
                "search box: lower and upper must be finite 1-D arrays of equal length with lower <= upper"
            )
        return cls(lo, hi)

    def sample(self, rng: np.random.Generator, count: int) -> Array:
        return self.lower + rng.random((count, self.lower.size)) * (self.upper - self.lower)

    def project(self, x: Array) -> Array:
        return np.clip(x, self.lower, self.upper)


@dataclass(frozen=True)
class SearchResult:
    """Best point a search found.

    Attributes
    ----------
    x : ndarray of shape (n,)
    fun : float
        Objective value at ``x``.
    history : ndarray of shape (iterations + 1,)
        Best-so-far objective after the start population and after each iteration.
    n_evaluations : int
        Points evaluated (never more than the budget).
    """

    x: Array
    fun: float
    history: Array
    n_evaluations: int


class Tally:
    """An objective with a budget: counts accepted points and shows them to an observer.

    ``peek`` evaluates without counting (the PSO's speculative blocks); ``accept``
    counts a prefix of the block last peeked at.  Non-finite values become +inf, so
    a diverging candidate loses every comparison instead of poisoning argmin.
    """

    def __init__(self, objective: Objective, budget: int, observe: Observer | None = None) -> None:
        self.objective = objective
        self.budget = int(budget)
        self.count = 0
        self.observe = observe

    @property
    def remaining(self) -> int:
        return self.budget - self.count

    def peek(self, x: Array) -> Array:
        values = np.asarray(self.objective(x), dtype=float)
        return np.where(np.isfinite(values), values, np.inf)

    def accept(self, x: Array, values: Array) -> None:
        self.count += len(x)
        if self.observe is not None:
            self.observe(x, values)

    def __call__(self, x: Array) -> Array:
        values = self.peek(x)
        self.accept(x, values)
        return values


def generator(seed: int | np.random.Generator | None) -> np.random.Generator:
    """The generator of a search: ``seed`` itself, seeded by it, or by :data:`DEFAULT_SEED` when None.

    Never an unseeded (entropy-seeded) generator.
    """
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(DEFAULT_SEED if seed is None else seed)


def start(space: Space, rng: np.random.Generator, size: int, x0: npt.ArrayLike | None) -> Array:
    """A uniform start population; ``x0`` (projected) in row 0."""
    pop = space.sample(rng, size)
    if x0 is not None:
        pop[0] = space.project(np.asarray(x0, dtype=float))
    return pop


#: Most points any search may evaluate: bounds the run time whatever option is given.
MAX_BUDGET = 10_000_000


def check_budget(owner: str, budget: int, population: int) -> None:
    """Budget in [1, MAX_BUDGET] and a positive population (a search without them returns nothing)."""
    if not 1 <= int(budget) <= MAX_BUDGET or int(population) < 1:
        raise ParameterError(
            f"{owner}: budget must be an int in [1, {MAX_BUDGET}] and population at least 1, "
            f"got {budget} and {population}"
        )


def launch(
    owner: str,
    objective: Objective,
    space: Space,
    rng: np.random.Generator,
    budget: int,
    population: int,
    x0: npt.ArrayLike | None,
    observe: Observer | None,
) -> tuple[Tally, Array, Array]:
    """The start every search shares: budget checked, start population drawn and evaluated.

    Returns
    -------
    tally : Tally
        The budgeted objective, the start population counted.
    x : ndarray of shape (min(population, budget), n)
    values : ndarray of shape (min(population, budget),)
    """
    check_budget(owner, budget, population)
    tally = Tally(objective, budget, observe)
    x = start(space, rng, min(int(population), tally.remaining), x0)
    return tally, x, tally(x)
