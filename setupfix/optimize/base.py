"""One interface for every optimiser: ``Optimizer(**hyper_parameters).solve(problem)``.

Metaheuristics share :class:`Metaheuristic`: randomness only through ``seed``
(a :class:`numpy.random.Generator` per solve), a budget of evaluated solutions,
and an :class:`Evaluator` that counts solutions, keeps the best one and the
best-so-far history for convergence plots.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import ClassVar, Final

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note
from setupfix.core.params import Constraint, Interval, ValidatedParams
from setupfix.optimize.problem import CorrectionProblem, OptimizeResult, Status, Stopped, TriageRecord
from setupfix.search import generator

__all__ = [
    "Optimizer",
    "Metaheuristic",
    "Evaluator",
    "GridSpace",
    "GridObjective",
    "make_result",
    "NO_BETTER_THAN_NONE",
    "SEED",
    "SOLUTIONS",
    "POPULATION",
    "count",
]

Array = npt.NDArray[np.float64]

#: Status of a result whose search found nothing better than no correction (x = 0 returned).
NO_BETTER_THAN_NONE: Final = "no_better_than_none"

#: Declared ranges shared by the optimisers (``setupfix.core.params``).  Budgets and
#: populations are bounded above so that no option makes a search run for hours.
SEED: list[Constraint] = [Interval(int, 0, None), None]
SOLUTIONS: list[Constraint] = [Interval(int, 1, 1_000_000)]
POPULATION: list[Constraint] = [Interval(int, 1, 100_000)]


def count(low: int, high: int) -> list[Constraint]:
    """An integer count in [low, high]."""
    return [Interval(int, low, high)]


def make_result(
    problem: CorrectionProblem,
    x: Array,
    *,
    optimizer: str,
    evaluations: int,
    seconds: float,
    status: Status,
    history: Array | None = None,
    bound: float | None = None,
    message: str | None = None,
    binding: tuple[str, ...] | None = None,
    guard: bool = True,
    given_up: tuple[str, ...] = (),
    notes: tuple[Note, ...] | None = None,
    stopped: Stopped | None = None,
    norm_ratio_max: float | None = None,
    triage: TriageRecord | None = None,
    leximin: tuple[tuple[float, int], ...] = (),
    path: str = "",
    stages: Mapping[str, float] | None = None,
) -> OptimizeResult:
    """Assemble an :class:`OptimizeResult` for corrections ``x`` (already on the grid).

    ``binding`` defaults to the dimensions at the minimum margin after ``x``; the
    exact optimiser passes the dimensions that prove its bound instead.

    The x = 0 guard: when ``guard`` is true (the default) and ``x`` has a smaller
    error budget f1 than no correction at all, the result is x = 0 with status
    :data:`NO_BETTER_THAN_NONE` and a message saying so — a search that did worse
    than doing nothing never sends a correction to the machine.  (An optimiser that
    trades f1 on purpose, e.g. for more dimensions in tolerance, passes
    ``guard=False`` and says why in its message.)

    ``given_up`` (the triage's dimensions left to the NC program): δ before and after and the
    binding dimensions are those of the other dimensions, the kept ones; the result lists them.

    ``notes`` (when given) are the result's, in place of the guard's; ``stopped``, ``norm_ratio_max``,
    ``triage``, ``leximin``, ``path`` and ``stages``: the exact optimiser's record (:class:`OptimizeResult`).
    """
    x = np.asarray(x, dtype=float).copy()
    x[np.abs(x) < 1e-12] = 0.0  # no "-0.000" in outputs
    f1, f2, _ = problem.evaluate(x)
    after = float(f1)
    before = problem.margin_before
    if given_up:
        keep = np.array([d not in given_up for d in problem.dimension_ids], dtype=bool)
        after = problem.kept_margin(x, given_up)
        before = problem.kept_margin(np.zeros_like(x), given_up)
        if binding is None:
            m = problem.margins(x)
            binding = tuple(
                d
                for d, v, k in zip(problem.dimension_ids, m, keep, strict=True)
                if k and v <= after + problem.resolution / 4
            )
    if guard and after < problem.margin_before:
        message = (
            f"the {optimizer} search found no correction better than none (best found: error budget "
            f"{after:+.4g} against {problem.margin_before:+.4g} without correction); no correction is "
            "recommended"
        )
        x = np.zeros_like(x)
        f1, f2, _ = problem.evaluate(x)
        after, status, binding = float(f1), NO_BETTER_THAN_NONE, None
        guarded: tuple[Note, ...] = (Note(message, kind="solver"),)
    else:
        guarded = ()
    if message is None:
        message = (
            "all measured dimensions predicted inside tolerance"
            if after >= 0
            else "no correction within the register limits brings every dimension into tolerance; "
            "this is the least-bad correction"
        )
    return OptimizeResult(
        x=x,
        margin_before=before,
        margin_after=after,
        norm=float(f2),
        optimizer=optimizer,
        evaluations=int(evaluations),
        seconds=float(seconds),
        status=status,
        message=message,
        binding=problem.binding(x) if binding is None else binding,
        history=history,
        bound=bound,
        notes=guarded if notes is None else notes,
        given_up=given_up,
        stopped=stopped,
        norm_ratio_max=norm_ratio_max,
        triage=triage,
        leximin=leximin,
        path=path,
        stages={} if stages is None else dict(stages),
    )


class Optimizer(ValidatedParams, ABC):
    """Base of all optimisers; hyper-parameters go to ``__init__``, data to ``solve``.

    Every ``__init__`` parameter is declared in ``_parameter_constraints``
    (:mod:`setupfix.core.params`); :func:`setupfix.optimize.get_optimizer` validates them
    right after construction and metaheuristics again before any work.
    """

    name: ClassVar[str] = ""

    @abstractmethod
    def solve(self, problem: CorrectionProblem) -> OptimizeResult:
        """Search corrections for ``problem``; never mutates it."""


class Evaluator:
    """Counts evaluated solutions and tracks the best one (maximising f = 10·f1 − f2).

    Parameters
    ----------
    problem : CorrectionProblem
    budget : int
        Number of solutions the search may evaluate; ``remaining`` tells what is left.
    """

    def __init__(self, problem: CorrectionProblem, budget: int) -> None:
        self.problem = problem
        self.budget = int(budget)
        self.count = 0
        self.best_x = np.zeros(problem.n_registers)
        self.best_f1 = -np.inf
        self.best_f2 = np.inf
        self.best_f = -np.inf
        self._history: list[tuple[float, float, float, float]] = []

    @property
    def remaining(self) -> int:
        return self.budget - self.count

    def __call__(self, x: Array) -> Array:
        """Evaluate grid solutions x of shape (n, n_registers) or (n_registers,); return f."""
        x = np.asarray(x, dtype=float)
        f1, f2, f = self.problem.evaluate(x)
        self.record(x, f1, f2, f)
        return f

    def record(self, x: Array, f1: Array, f2: Array, f: Array) -> None:
        """Count solutions x already evaluated elsewhere (their f1, f2, f) and keep the best."""
        flat_f = np.atleast_1d(f)
        i = int(np.argmax(flat_f))
        self.count += flat_f.size
        if flat_f[i] > self.best_f:
            self.best_f = float(flat_f[i])
            self.best_f1 = float(np.atleast_1d(f1)[i])
            self.best_f2 = float(np.atleast_1d(f2)[i])
            self.best_x = np.atleast_2d(x)[i].copy()
        self._history.append((self.count, self.best_f1, self.best_f2, self.best_f))

    @property
    def history(self) -> Array:
        """Best-so-far [evaluations, f1, f2, f] after each call, shape (k, 4)."""
        return np.array(self._history, dtype=float).reshape(-1, 4)


class GridSpace:
    """The register grid of a problem as a :class:`setupfix.search.Space`.

    Start points are uniform in the bounds and snapped (:meth:`CorrectionProblem.sample`);
    every move is snapped onto the grid inside the bounds (:meth:`CorrectionProblem.snap`),
    so fixed registers (bounds 0, 0) never move.
    """

    def __init__(self, problem: CorrectionProblem) -> None:
        self.problem = problem
        self.lower = problem.lb
        self.upper = problem.ub

    def sample(self, rng: np.random.Generator, count: int) -> Array:
        return self.problem.sample(rng, count)

    def project(self, x: Array) -> Array:
        return self.problem.snap(x)


class GridObjective:
    """−f (eq. 10) of grid solutions for the minimising searches of :mod:`setupfix.search`.

    :meth:`observe` hands the solutions a search counts (always a prefix of the
    block last evaluated) with their f1, f2 and f to the :class:`Evaluator`, so no
    solution is evaluated twice.
    """

    def __init__(self, evaluate: Evaluator) -> None:
        self.evaluate = evaluate
        self._last: tuple[Array, Array, Array] = (np.empty(0), np.empty(0), np.empty(0))

    def __call__(self, x: Array) -> Array:
        f1, f2, f = self.evaluate.problem.evaluate(x)
        self._last = (np.atleast_1d(f1), np.atleast_1d(f2), np.atleast_1d(f))
        return -self._last[2]

    def observe(self, x: Array, values: Array) -> None:
        m = len(x)
        f1, f2, f = self._last
        self.evaluate.record(x, f1[:m], f2[:m], f[:m])


class Metaheuristic(Optimizer):
    """Population search with a solution budget and a seed.

    Subclasses implement :meth:`_search`, drawing all randomness from ``rng`` and
    evaluating only through ``evaluate`` (grid points within bounds).
    """

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {"n_solutions": SOLUTIONS, "seed": SEED}

    def __init__(self, *, n_solutions: int, seed: int | None = None) -> None:
        self.n_solutions = n_solutions
        self.seed = seed

    @abstractmethod
    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        """Run the search until ``evaluate.remaining`` is spent."""

    def solve(self, problem: CorrectionProblem) -> OptimizeResult:
        self.validate_params()
        rng = generator(self.seed)  # seed None: setupfix.search.DEFAULT_SEED, never an unseeded run
        evaluate = Evaluator(problem, self.n_solutions)
        start = time.perf_counter()
        self._search(problem, rng, evaluate)
        seconds = time.perf_counter() - start
        return make_result(
            problem,
            evaluate.best_x,
            optimizer=self.name,
            evaluations=evaluate.count,
            seconds=seconds,
            status="budget",
            history=evaluate.history,
        )
