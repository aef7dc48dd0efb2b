"""One exact solve's data and solver resources: the rows in grid units, its clock, its HiGHS models.

A :class:`Session` is made at the start of each solve and dropped at its end: every
HiGHS model it builds lives only as long as the solve, so nothing carries over from one
report to the next — no basis, no incumbent, and no run clock (HiGHS adds the run time of
every run of one model, and compares its time limit with that sum: a model kept across
thousands of reports ended up with no time left at all).  The answer to a report is
therefore the answer it gets in a fresh process, whatever was solved before and in which
thread.  Only data derived from G, the box and the costs (row gcds, pairs of rows, the LP's
matrix, NNLS systems) is memoised across solves (:func:`derived`): pure functions of those bytes, kept
read-only.

Grid units (see :func:`setupfix.optimize.exact.lp_bound.margin_rows`): corrections k in
register steps, margin rows ``m_j(k) = g_j − G_j·k`` (eqs. 5–6 per dimension), error
budget ``t(k) = min_j m_j(k)`` (f1, eq. 8), norm ``f(k) = Σ c_i k_i²`` (f2, eq. 9).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypeVar, cast

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.grid import (
    PairStructure,
    least_distance,
    least_distance_system,
    next_level,
    pair_structure,
    rounded_rhs,
    row_gcd,
)
from setupfix.optimize.exact.highs import INF, Colwise, LinearModel, Solve
from setupfix.optimize.exact.least_norm.shop import least_distance_working_set
from setupfix.optimize.exact.settings import ExactSettings
from setupfix.optimize.exact.work import CURRENT, Meter, wall

__all__ = ["DERIVED", "Clock", "Derived", "GridRows", "Relaxation", "Session", "derived"]

Array = npt.NDArray[np.float64]


class Clock:
    """Work budget of one solve [work units, :mod:`setupfix.optimize.exact.work`] and the wall time
    spent per stage (a record only: no stage reads it).

    ``start`` and ``deadline`` are readings of :func:`~setupfix.optimize.exact.work.now` (work spent by
    this solve), so a stage's end depends on the work done, never on the machine's load.  The clock
    makes its :class:`~setupfix.optimize.exact.work.Meter` the current one; ``guard`` [s] is the
    wall-clock limit against a hang (inf: none), ``node_work`` what a MIP node counts.
    """

    def __init__(self, limit: float, guard: float = float("inf"), node_work: float = 50.0) -> None:
        self.wall_start = wall()
        self.meter = Meter(node_work=node_work, guard=self.wall_start + guard)
        CURRENT.set(self.meter)
        self.start = 0.0
        self.deadline = self.start + limit
        self.stages: dict[str, float] = {}
        self._mark = self.wall_start

    def now(self) -> float:
        """Work spent so far (+inf once the wall-clock guard fired)."""
        return self.meter.now()

    def left(self) -> float:
        return self.deadline - self.meter.now()

    @property
    def fired(self) -> bool:
        """The wall-clock guard stopped the solve."""
        return self.meter.check_guard()

    def lap(self, stage: str) -> None:
        now = wall()
        self.stages[stage] = self.stages.get(stage, 0.0) + now - self._mark
        self._mark = now


@dataclass(frozen=True)
class Derived:
    """Data derived from G, the box and the costs alone (never from a report's deviations).

    Attributes
    ----------
    d : ndarray of shape (r,)
        Per-row gcd of integer rows (0: not all integers) — :func:`~setupfix.optimize.exact.grid.row_gcd`.
    zero : ndarray of bool, shape (r,)
        Rows with no coefficient (every register fixed for that dimension).
    pairs : PairStructure or None
        Opposite integer rows (:func:`~setupfix.optimize.exact.grid.pair_structure`).
    lp_matrix : Colwise
        [G | 1], the matrix of the LP of eq. 8 (:meth:`Session.lp_model`).
    all_integer : bool
        Every row integer or zero (:attr:`GridRows.all_integer`).
    nnls : dict
        The b-independent NNLS systems (:func:`~setupfix.optimize.exact.grid.least_distance_system`)
        per set of finite rows, filled on first use.
    memo : dict
        Other results of G alone, keyed by the caller (:meth:`GridRows.memo`): the leximin
        stage's span closures, climb moves and row grouping — a batch of one process model
        computes each once, not once per report.
    """

    d: Array
    zero: npt.NDArray[np.bool_]
    pairs: PairStructure | None
    lp_matrix: Colwise
    all_integer: bool
    nnls: dict[bytes, tuple[Array, Array]] = field(default_factory=dict)
    memo: dict[tuple[object, ...], object] = field(default_factory=dict)


#: Derived data of the last few (G, box, cost): pure functions of those bytes, read-only arrays, so a
#: memo can never change an answer (it only spares a batch of one process model recomputing them).
DERIVED: dict[tuple[object, ...], Derived] = {}
#: Most entries of one :attr:`Derived.memo` (cleared when full: a long batch never grows it without bound).
MEMO_MAX = 4096
_MISSING = object()
T = TypeVar("T")
_DERIVED_MAX = 8
_DERIVED_LOCK = threading.Lock()


def _read_only(*arrays: npt.NDArray[np.generic]) -> None:
    for a in arrays:
        a.flags.writeable = False


def derived(g_rows: Array, kmin: Array, kmax: Array, cost: Array) -> Derived:
    """:class:`Derived` of exactly these arrays (memoised by their bytes)."""
    key = (g_rows.shape, g_rows.tobytes(), kmin.tobytes(), kmax.tobytes(), cost.tobytes())
    found = DERIVED.get(key)
    if found is None:
        pairs = pair_structure(g_rows, kmin, kmax)
        lp_matrix = Colwise.of(np.hstack([g_rows, np.ones((g_rows.shape[0], 1))]))
        d, zero = row_gcd(g_rows), ~np.any(g_rows != 0, axis=1)
        found = Derived(d, zero, pairs, lp_matrix, bool(np.all((d > 0) | zero)))
        _read_only(found.d, found.zero, lp_matrix.start, lp_matrix.index, lp_matrix.value)
        if pairs is not None:
            _read_only(pairs.inverse, pairs.ia, pairs.ib, pairs.d, pairs.zlo, pairs.zhi)
        with _DERIVED_LOCK:
            while len(DERIVED) >= _DERIVED_MAX:
                del DERIVED[next(iter(DERIVED))]
            found = DERIVED.setdefault(key, found)
    return found


@dataclass(frozen=True)
class GridRows:
    """The problem of one solve in grid units.

    Attributes
    ----------
    g_rows : ndarray of shape (r, n)
        G over the free registers; g : ndarray of shape (r,) (margin ≥ t ⇔ G k + t ≤ g).
    kmin, kmax, cost : ndarray of shape (n,)
        Register bounds [steps] and costs c_i of eq. 9.
    derived : Derived
        What follows from G, the box and the costs alone.
    """

    g_rows: Array
    g: Array
    kmin: Array
    kmax: Array
    cost: Array
    derived: Derived = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "derived", derived(self.g_rows, self.kmin, self.kmax, self.cost))

    @property
    def d(self) -> Array:
        return self.derived.d

    @property
    def zero(self) -> npt.NDArray[np.bool_]:
        return self.derived.zero

    @property
    def pairs(self) -> PairStructure | None:
        return self.derived.pairs

    @property
    def n_free(self) -> int:
        return int(self.kmin.size)

    @property
    def all_integer(self) -> bool:
        """Every row integer or zero: an empty rounded system lowers the level (:func:`next_level`)."""
        return self.derived.all_integer

    def rounded(self, level: float) -> Array:
        """Rows b with {G k ≤ b} ⊇ {grid k : t(k) ≥ level} (:func:`~setupfix.optimize.exact.grid.rounded_rhs`)."""
        return rounded_rhs(self.g, self.d, self.zero, level)

    def below(self, b: Array) -> float:
        """The next level down once the rounded rows ``b`` hold no grid point."""
        return next_level(self.g, self.d, b)

    def memo(self, key: tuple[object, ...], make: Callable[[], T], most: int = MEMO_MAX) -> T:
        """``make()``, computed once per G, box and costs for this key (at most ``most`` kept: the memo is
        cleared when full).

        ``make`` must depend on G, the box, the costs and the key only (never on g): the memo
        is shared by every report of one process model, and by threads; arrays in it are read-only.
        """
        memo = self.derived.memo
        found = memo.get(key, _MISSING)
        if found is _MISSING:
            found = make()
            if isinstance(found, np.ndarray):
                found.flags.writeable = False
            if len(memo) >= most:
                memo.clear()
            memo[key] = found
        return cast(T, found)

    def nnls_system(self, keep: npt.NDArray[np.bool_]) -> tuple[Array, Array]:
        """The b-independent NNLS system of the rows ``keep`` (memoised with :class:`Derived`)."""
        key = keep.tobytes()
        system = self.derived.nnls.get(key)
        if system is None:
            system = least_distance_system(self.g_rows[keep], self.cost)
            _read_only(*system)
            system = self.derived.nnls.setdefault(key, system)
        return system


@dataclass(frozen=True)
class Relaxation:
    """Continuous least norm min Σ c k² s.t. G k ≤ b, box — its point and multipliers (≥ 0).

    Attributes
    ----------
    b : ndarray of shape (r,)
        The rows it was solved for (+inf: no row).
    k : ndarray of shape (n,)
    lam_rows : ndarray of shape (r,); lam_lo, lam_hi : ndarray of shape (n,)
        Multipliers of G k ≤ b, k ≥ kmin and k ≤ kmax (one common positive scale).
    """

    b: Array
    k: Array
    lam_rows: Array
    lam_lo: Array
    lam_hi: Array

    def multipliers(self) -> tuple[Array, Array, Array]:
        return self.lam_rows, self.lam_lo, self.lam_hi


class Session:
    """Resources of one solve: its clock, and the HiGHS models and NNLS systems built on first use.

    Parameters
    ----------
    rows : GridRows
    settings : ExactSettings
    time_limit : float, optional
        Work units for the whole solve (default ``settings.work_limit``; the stages' shares are of it).
    clock : Clock, optional
        The solve's clock, if started earlier (default: it starts now, with no wall-clock guard).
    """

    def __init__(
        self, rows: GridRows, settings: ExactSettings, time_limit: float | None = None, clock: Clock | None = None
    ) -> None:
        self.rows = rows
        self.settings = settings
        self.time_limit = settings.work_limit if time_limit is None else time_limit
        self.clock = Clock(self.time_limit, node_work=settings.node_work) if clock is None else clock
        self._lp: LinearModel | None = None
        self._qp: LinearModel | None = None

    @property
    def small(self) -> bool:
        """Few enough constraints (rows + 2·registers) for NNLS on the whole system."""
        return bool(self.rows.g_rows.shape[0] + 2 * self.rows.n_free <= self.settings.nnls_max_rows)

    def lp_model(self) -> LinearModel:
        """max t s.t. G k + t ≤ g, k in the box (eq. 8 as an LP; row bounds set per use)."""
        if self._lp is None:
            r = self.rows.g_rows.shape[0]
            self._lp = LinearModel(
                np.r_[np.zeros(self.rows.n_free), -1.0],
                self.rows.derived.lp_matrix,
                np.full(r, -INF),
                np.zeros(r),
                np.r_[self.rows.kmin, -INF],
                np.r_[self.rows.kmax, INF],
            )
            if self.small:  # presolve costs more than it saves on a few dozen rows (the reference LP of
                self._lp.skip_presolve()  # bench/leximin_speed.py: 1.126 ms with it, 0.698 ms without)
        return self._lp

    def drop_lp(self) -> None:
        """Forget the LP model (a retry from scratch after a HiGHS failure)."""
        self._lp = None

    def rounded_rows_feasible(
        self, b: Array, time_limit: float | None = None, warm: bool = False
    ) -> tuple[str, Array | None]:
        """Whether G k ≤ b has a solution in the box: the LP with t fixed at 0 — HiGHS's status (its
        words on an error) and the vertex.  ``warm``: from the last basis (the leximin levels' tests)."""
        lp = self.lp_model()
        if warm:
            lp.keep_basis()
        n = np.array([self.rows.n_free], dtype=np.int32)
        lp.set_row_bounds(np.full(b.size, -INF), np.where(np.isfinite(b), b, INF))
        lp.set_col_bounds(n, np.zeros(1), np.zeros(1))
        try:
            res = lp.solve(max(self.clock.left() if time_limit is None else time_limit, 1e-3))
        finally:
            lp.set_col_bounds(n, np.array([-INF]), np.array([INF]))
        status = res.status if res.status != "error" else f"HiGHS: {res.detail}"
        return status, None if res.x is None else res.x[:-1]

    def least_norm(self, b: Array) -> tuple[str, Relaxation | None]:
        """Least Σ c k² with G k ≤ b in the box: ("optimal", relaxation), ("infeasible", None) …

        Small problems by NNLS (:func:`~setupfix.optimize.exact.grid.least_distance`, a fraction of
        a millisecond), larger ones by NNLS on a working set of rows, HiGHS's QP solver last.
        """
        rows = self.rows
        g_rows, kmin, kmax, cost = rows.g_rows, rows.kmin, rows.kmax, rows.cost
        if self.small:
            status, out = least_distance(g_rows, b, kmin, kmax, cost, rows.nnls_system(np.isfinite(b)))
            if status != "unknown":
                return status, None if out is None else Relaxation(b, *out)
        elif self.settings.working_set_nnls:
            status, out = least_distance_working_set(g_rows, b, kmin, kmax, cost, self.clock.deadline)
            if status != "unknown" or self.clock.left() <= 0:
                return status, None if out is None else Relaxation(b, *out)
        if self._qp is None:
            r, n = g_rows.shape
            self._qp = LinearModel(np.zeros(n), g_rows, np.full(r, -INF), np.zeros(r), kmin, kmax)
            self._qp.set_hessian_diagonal(2 * cost)
        self._qp.set_row_bounds(np.full(b.size, -INF), np.where(np.isfinite(b), b, INF))
        res = self._qp.solve(max(self.clock.left(), 1e-3))
        if res.status != "optimal" or res.x is None or res.row_dual is None or res.col_dual is None:
            return res.status, None
        return "optimal", Relaxation(
            b, res.x, np.maximum(-res.row_dual, 0.0), np.maximum(res.col_dual, 0.0), np.maximum(-res.col_dual, 0.0)
        )

    def max_margin_milp(self, t_lo: float, t_hi: float, start: Array | None, time_limit: float) -> Solve:
        """max t s.t. G k + t ≤ g, k integer in the box, t ∈ [t_lo, t_hi] (eq. 8 on the grid)."""
        g_rows, r, n = self.rows.g_rows, self.rows.g_rows.shape[0], self.rows.n_free
        model = LinearModel(
            np.r_[np.zeros(n), -1.0],
            np.hstack([g_rows, np.ones((r, 1))]),
            np.full(r, -INF),
            self.rows.g,
            np.r_[self.rows.kmin, t_lo],
            np.r_[self.rows.kmax, t_hi],
            integer=np.r_[np.ones(n, bool), False],
        )
        return model.solve(time_limit, None if start is None else np.r_[start, t_lo])
