"""The work clock of one exact solve: stages end on work done, never on the wall clock.

Which stage of a solve ends, and where, must not depend on the machine's load: the same report
gives the same correction on an idle box and on one whose every core is busy.  So the solve's
stages share a budget of **work units** (``ExactSettings.work_limit``), not of seconds.  A HiGHS
run costs its model's size s = (rows + columns) / 100 (at least 1) for its set-up, and s per
simplex or QP iteration, :data:`IPM_ITERATION` · s per interior-point iteration,
``ExactSettings.node_work`` · s per branch-and-bound node and, for a MIP, its root's presolve,
probing and cuts by the model's size (:func:`mip_root_work`) (:func:`run_work`): one unit is about one
simplex iteration on a 100-row model, some 10 µs on the 2-core test machine
(``bench/work_limits.py``).  HiGHS is given the matching iteration and node limits
(:func:`run_limits`), which it obeys deterministically (single thread, no time-dependent
heuristics).  Every reading the stages used to take from ``time.perf_counter()`` is :func:`now`,
the work spent so far in the current solve.

The wall clock remains only as a guard against a hang (``--time-limit``): when it passes its
deadline the :class:`Meter` is marked ``fired``, :func:`now` answers +inf (every stage stops at
its next check, every HiGHS run is interrupted) and the optimiser returns no correction with the
stopped status (:mod:`setupfix.optimize.exact.solve`) — a stopped solve is then a hold, never a
different correction.

The current meter is a context variable: each thread (a batch's workers) and each solve has its
own, set by :class:`~setupfix.optimize.exact.session.Clock`.
"""

from __future__ import annotations

import math
import time
from contextvars import ContextVar
from dataclasses import dataclass

__all__ = [
    "CURRENT",
    "IPM_ITERATION",
    "MIN_RUN",
    "MIP_ROOT_DIVISOR",
    "Meter",
    "charge",
    "current",
    "mip_root_work",
    "model_size",
    "now",
    "run_limits",
    "run_work",
    "wall",
    "wall_clock",
]

#: Fewest work units a HiGHS run is given (a run "with no time left" still proves a small LP: the
#: wall-clock version gave it 1 ms).
MIN_RUN = 1000.0
#: An interior-point iteration counts this many simplex iterations (a factorisation each).
IPM_ITERATION = 20.0
#: A MIP's root work is rows × integer columns / this (:func:`mip_root_work`).
MIP_ROOT_DIVISOR = 50.0
#: HiGHS's own limits are ints; no run is given more than this.
_MAX_INT = 2**31 - 1


def wall_clock() -> float:
    """``time.perf_counter()``: the wall clock the solver reads (the hang guard, the stages' record).

    Every reading goes through :func:`wall` (which looks this name up at each call), so a test can
    run the solver's clock fast by replacing this one function.
    """
    return time.perf_counter()


def wall() -> float:
    """The solver's wall-clock reading [s] (:func:`wall_clock`)."""
    return wall_clock()


@dataclass
class Meter:
    """Work spent by one solve [units] and its wall-clock guard.

    Attributes
    ----------
    spent : float
        Work units spent so far (HiGHS iterations, nodes × ``node_work``, explicit charges).
    node_work : float
        Units one branch-and-bound node counts.
    guard : float
        :func:`wall_clock` reading at which the solve is stopped as hung (inf: never).
    fired : bool
        The guard has fired: the solve is stopped and gives no correction.
    """

    spent: float = 0.0
    node_work: float = 50.0
    guard: float = math.inf
    fired: bool = False

    def check_guard(self) -> bool:
        """Whether the wall-clock guard has fired (it is read here, and in HiGHS's interrupts)."""
        if not self.fired and self.guard < math.inf and wall() > self.guard:
            self.fired = True
        return self.fired

    def guard_left(self) -> float:
        """Seconds of wall time before the guard fires (inf: no guard)."""
        return self.guard - wall() if self.guard < math.inf else math.inf

    def now(self) -> float:
        """Work spent so far; +inf once the guard has fired (every deadline has passed)."""
        return math.inf if self.check_guard() else self.spent


CURRENT: ContextVar[Meter | None] = ContextVar("setupfix_exact_meter", default=None)


def current() -> Meter:
    """The meter of the solve running in this context (a fresh, unlimited one if none is)."""
    meter = CURRENT.get()
    if meter is None:
        meter = Meter()
        CURRENT.set(meter)
    return meter


def now() -> float:
    """Work units spent by the current solve (+inf once its wall-clock guard fired)."""
    return current().now()


def charge(units: float) -> None:
    """Count ``units`` of work done outside HiGHS (a listing, a descent) to the current solve."""
    current().spent += float(units)


def model_size(rows: int, cols: int) -> float:
    """The work of one iteration on a model of this shape [units]: (rows + columns) / 100, at least 1."""
    return max((rows + cols) / 100.0, 1.0)


def run_work(size: float, simplex: int, ipm: int, nodes: int, node_work: float, root: float = 0.0) -> float:
    """Work units of one HiGHS run: its set-up and its iterations and nodes, each ``size`` units
    (negative counts, HiGHS's "not run", count 0), and ``root`` (:func:`mip_root_work`)."""
    return size * (1.0 + max(simplex, 0) + IPM_ITERATION * max(ipm, 0) + node_work * max(nodes, 0)) + root


def mip_root_work(rows: int, integers: int) -> float:
    """Work units of a MIP's presolve, probing and root cuts, which HiGHS counts in neither iterations nor
    nodes: rows × integer columns / :data:`MIP_ROOT_DIVISOR` (0.1–1 s at 1,000 rows × 460 binaries,
    some 10,000 simplex iterations on a 100-row model; ``bench/work_limits.py``)."""
    return rows * integers / MIP_ROOT_DIVISOR


def run_limits(allowance: float, node_work: float, size: float = 1.0) -> tuple[int, int, int]:
    """HiGHS's (simplex/QP iteration limit, IPM iteration limit, node limit) for a run of a model of
    ``size`` (:func:`model_size`) allowed ``allowance`` work units (at least :data:`MIN_RUN`)."""
    units = float(allowance) if allowance >= MIN_RUN else MIN_RUN  # nan, -inf, too little: MIN_RUN
    steps = min(units / size, float(_MAX_INT))
    iterations = max(math.ceil(steps), 1)
    ipm = max(math.ceil(steps / IPM_ITERATION), 1)
    nodes = min(max(math.ceil(steps / node_work), 1), _MAX_INT)
    return iterations, ipm, nodes
