"""Exact optimum of the setup-correction problem with HiGHS (highspy).

The max–min objective f1 (eq. 8) is linear in the corrections, so the problem is a
linear programme, and on the register grid a mixed-integer one.  Everything is
solved in grid units (k = x / resolution, margins in resolution steps), which
keeps the numbers near 1–100 where the solver's tolerances are meaningful.

Input quantum
-------------
Deviations are rounded to 1/1000 of the register resolution (1 nm on a 0.001 mm
grid) before anything is solved, so the answer does not depend on the last bits
of the input: a report read from CSV and the same numbers computed in memory
(``24.9691 − 25`` against ``-0.0309``) give the same corrections.  Limits are
taken as the model states them.  Reported margins use the unrounded deviations.

Stages, and the proofs that let one be skipped
----------------------------------------------
1. **LP bound** — maximise t subject to every margin ≥ t and the register bounds;
   t_LP bounds every correction.  Its dual prices name the binding dimensions.
   From the same duals, :func:`~setupfix.optimize._grid.dual_bound` re-proves the
   bound in numpy, and :func:`~setupfix.optimize._grid.pair_bound` lowers it where
   two dimensions move alike and the even split of their difference is off the
   grid.  U = the smaller of the two bounds every grid point must respect.
2. **Grid optimum** — if the LP point rounded to the grid already reaches U, it is
   optimal (nothing on the grid exceeds U): no MILP.  Otherwise levels of rounded rows
   from U down: an empty continuous system lowers the level; small problems list growing
   ellipsoids around its continuous least-norm point (bounded work): a point found reaches
   the level, a list that closes also proves the least norm there (stage 3 is skipped), a
   list holding the whole box with no point proves the level empty; then a feasibility
   MILP; only then the MILP "max t, k integer", bracketed t ∈ [t(rounded point), U],
   started from the rounded point.
   A HiGHS failure ("Solve error") is retried once with the lower bracket removed,
   and reported as such in ``notes``.
3. **Least norm** — among grid points with margin ≥ t*, the least Σ cost_i·k_i²
   (eq. 9; cost = 1 by default).  The continuous QP (NNLS; on a working set of rows
   for large problems) gives a point and multipliers; the multipliers bound every
   feasible point's norm from below by an ellipsoid around that point
   (:func:`~setupfix.optimize._grid.lagrangian_ball`), and the integer points inside
   it that could beat the best known point are listed exhaustively, pruned by the rows
   and by the Lagrangian dual bound of the coordinates not yet fixed
   (:func:`~setupfix.optimize._grid.enumerate_ball`) — the least one is the proven grid
   least norm (ties: the lexicographically smallest).  If the best known point already meets the bound,
   nothing is listed.  Large problems (more than ``ELLIPSOID_MAX_REGISTERS`` free
   registers, or a list too long): a near-least incumbent from the least norm in the
   unit box around the rounded continuous point (one MILP with a linear objective;
   one step wider if that box is empty), then the exact chord MILP — on integers k²
   is the upper envelope of the chords (2j+1)|k| − j(j+1), added lazily where a
   solution violates s_i ≥ k_i² — restricted to the box the same multipliers prove
   holds every point at most as large as the incumbent
   (:func:`~setupfix.optimize._least_norm.lagrangian_box`).  If the limit stops the
   proof, the best point is improved by coordinate descent and the result states a
   certified bound on ‖x‖ / least norm (``extra["norm_ratio_max"]``).

One ``time_limit`` bounds the wall time of the whole solve.  The grid-optimum
stage may use half of what is left, so the least-norm stage always runs: if a
stage stops at the limit, its best point is used, the least-norm stage still
shrinks the correction at the error budget reached, and the status, the message,
``notes`` and ``extra["stopped"]`` say which stage stopped and why.  The LP bound
is always reported.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager

import numpy as np
import numpy.typing as npt
from threadpoolctl import ThreadpoolController

from setupfix.errors import Note, SolverError
from setupfix.params import Interval
from setupfix.optimize._base import Optimizer, make_result
from setupfix.optimize._grid import (TOL, dual_bound, ellipsoid_search, grid_margins, lagrangian_ball,
                                     least_distance, least_distance_system,
                                     next_level,
                                     PairStructure, pair_bound, pair_structure, rounded_rhs, row_gcd)
from setupfix.optimize._highs import INF, LinearModel, Solve
from setupfix.optimize._least_norm import (box_least_norm, chord_least_norm, descend, lagrangian_box,
                                           least_distance_working_set, lower_bound_ratio)
from setupfix.optimize._problem import CorrectionProblem, OptimizeResult

__all__ = ["ExactOptimizer", "margin_rows", "QUANTUM"]

Array = npt.NDArray[np.float64]

#: Deviations are rounded to this fraction of the register resolution before solving.
QUANTUM = 1e-3
#: Most free registers for which the least-norm proof lists the grid points of the dual ellipsoid.
ELLIPSOID_MAX_REGISTERS = 120
#: Largest list of (partial) integer points per coordinate, and most array elements touched in all, that
#: the least-norm proof may enumerate before it uses the MILPs (a list of that size is some 5 ms of numpy).
ENUMERATION_LIMIT = 20_000
ENUMERATION_WORK = 400_000
#: The least-norm proof in the Lagrangian box is one MILP with every chord up to these sizes
#: (else chords are added lazily).
BOX_PROOF_MAX_REGISTERS = 40
BOX_PROOF_MAX_CHORDS = 20_000
#: Largest constraint count whose continuous least-norm point is found by NNLS (else HiGHS QP).
NNLS_MAX_ROWS = 600
#: Larger problems: NNLS on a working set of rows (False: HiGHS's QP solver at once).
WORKING_SET_NNLS = True
#: Shares of the time left that the least-norm stage gives the box MILPs around the rounded continuous
#: point (the incumbent), and the time kept back for the descent when the proof stops at the limit.
BOX_SHARE = 0.25
#: The same share when the grid-optimum stage was stopped (the incumbent matters more than a proof).
STOPPED_BOX_SHARE = 0.8
#: Relative gap at which those box MILPs stop (they look for an incumbent; the proof comes after).
INCUMBENT_GAP = 1e-4
DESCENT_RESERVE = 0.03
#: Most (partial) points per coordinate, and array elements in all, that the grid-optimum stage lists in the
#: ellipsoids around the rounded rows' least-norm point (a point at its bound, and the least norm there).
SEARCH_LIMIT = 20_000
SEARCH_WORK = 400_000
#: A cold LP with more rows than this is solved by HiGHS's interior-point method (with crossover, so the
#: duals are a basis' and later solves of the kept model warm-start the simplex from it).
IPM_MIN_ROWS = 2000
#: Share of the grid-optimum stage's time a feasibility MILP may use.
MILP_SHARE = 0.5
#: Share of the whole time limit kept for the least-norm stage (HiGHS may overrun a limit a little).
LEAST_NORM_SHARE = 0.5
#: Levels the grid-optimum stage may descend by rounded rows before it uses the MILP.
LEVEL_STEPS = 40


def _ceil_bound(lower: float, cost: Array) -> float:
    """A lower bound on Σ c k² over integers, rounded up to an integer when every cost is one."""
    if np.all(cost == np.rint(cost)):
        return float(np.ceil(lower - 1e-6))
    return lower - 1e-9 * max(1.0, abs(lower))


def margin_rows(problem: CorrectionProblem) -> tuple[Array, Array]:
    """Margin constraints in grid units: ``G·k + t ≤ g`` means every margin ≥ t.

    For dimension q with composite column a_q, measured deviation d_q and limits
    L_q < U_q the two margins are U_q − (d_q + h·a_qᵀk) and (d_q + h·a_qᵀk) − L_q
    (eqs. 5–6 per dimension); in steps of h they give the rows
    ``a_qᵀk + t ≤ U_q/h − d_q/h`` and ``−a_qᵀk + t ≤ d_q/h − L_q/h``, with d_q/h
    rounded to :data:`QUANTUM` steps.

    Returns
    -------
    G : ndarray of shape (n_rows, n_free)
        Rows over the free registers only.
    g : ndarray of shape (n_rows,)
    """
    h = problem.resolution
    a = problem.composite[problem.free].T  # (m, n_free)
    upper_ok = np.isfinite(problem.upper)
    lower_ok = np.isfinite(problem.lower)
    dev = np.round(problem.deviation / h / QUANTUM) * QUANTUM
    g_rows = np.vstack([a[upper_ok], -a[lower_ok]])
    g = np.concatenate([(problem.upper / h)[upper_ok] - dev[upper_ok],
                        dev[lower_ok] - (problem.lower / h)[lower_ok]])
    return g_rows, g


def _rows_to_dimensions(problem: CorrectionProblem, rows: npt.NDArray[np.bool_]) -> tuple[str, ...]:
    """Dimension IDs of flagged margin rows (upper-limit rows first, as in :func:`margin_rows`)."""
    ids = np.array(problem.dimension_ids, dtype=object)
    upper_ids = ids[np.isfinite(problem.upper)]
    lower_ids = ids[np.isfinite(problem.lower)]
    flagged = set(upper_ids[rows[: upper_ids.size]]) | set(lower_ids[rows[upper_ids.size:]])
    return tuple(d for d in problem.dimension_ids if d in flagged)


def _lp_model(g_rows: Array, kmin: Array, kmax: Array) -> LinearModel:
    """max t s.t. G k + t ≤ g (row bounds set per report), k in the box."""
    r, n = g_rows.shape
    model = LinearModel(np.r_[np.zeros(n), -1.0], np.hstack([g_rows, np.ones((r, 1))]), np.full(r, -INF),
                        np.zeros(r), np.r_[kmin, -INF], np.r_[kmax, INF])  # t: bounded by every row
    return model


_CONTROLLER: ThreadpoolController | None = None
_THREAD = threading.local()


def _blas_single_thread() -> AbstractContextManager[object]:
    """BLAS limited to one thread; the controller (a scan of loaded libraries) is made once."""
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1)


class _Clock:
    """Deadline of one solve and the wall time spent per stage."""

    def __init__(self, limit: float) -> None:
        self.start = time.perf_counter()
        self.deadline = self.start + limit
        self.stages: dict[str, float] = {}
        self._mark = self.start

    def left(self) -> float:
        return self.deadline - time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.stages[stage] = self.stages.get(stage, 0.0) + now - self._mark
        self._mark = now


class _Cache:
    """Solver models kept across reports of one process model (same G and box).

    One per thread (HiGHS objects are not shared between threads): a batch or the TUI
    that solves in worker threads keeps one set of models per worker.
    """

    def __init__(self) -> None:
        self.key: tuple[object, ...] | None = None
        self.g_rows: Array | None = None
        self.models: dict[str, LinearModel] = {}
        self.derived: dict[str, object] = {}

    def structure(self, g_rows: Array, kmin: Array, kmax: Array, cost: Array) -> tuple[Array, PairStructure | None]:
        """Per-row gcds and the pair structure of G (computed once per G and box)."""
        self.get("lp", g_rows, kmin, kmax, cost, lambda: _lp_model(g_rows, kmin, kmax))
        if "gcd" not in self.derived:
            self.derived["gcd"] = row_gcd(g_rows)
            self.derived["pairs"] = pair_structure(g_rows, kmin, kmax)
        return self.derived["gcd"], self.derived["pairs"]  # type: ignore[return-value]

    def get(self, name: str, g_rows: Array, kmin: Array, kmax: Array, cost: Array,
            build: Callable[[], LinearModel]) -> LinearModel:
        key = (g_rows.shape, kmin.tobytes(), kmax.tobytes(), cost.tobytes())
        if key != self.key or self.g_rows is None or not np.array_equal(g_rows, self.g_rows):
            self.key, self.g_rows, self.models, self.derived = key, g_rows.copy(), {}, {}
        if name not in self.models:
            self.models[name] = build()
        return self.models[name]


class ExactOptimizer(Optimizer):
    """Provably optimal corrections on the register grid (the default optimiser).

    Parameters
    ----------
    grid : bool, default=True
        Solve on the register grid.  False returns the continuous LP optimum with
        the least weighted Euclidean norm (not on the grid).
    time_limit : float, default=2.0
        Seconds of wall time for the whole solve; when a stage hits it, the best
        point found is used and the result says which stage stopped.
    seed : int, optional
        Accepted for interface symmetry; the solver is deterministic.
    """

    name = "exact"
    _parameter_constraints = {
        "grid": [bool],
        "time_limit": [Interval(float, 0.0, None, closed="neither")],
        "seed": [Interval(int, 0, None), None],
    }

    def __init__(self, *, grid: bool = True, time_limit: float = 2.0, seed: int | None = None) -> None:
        self.grid = grid
        self.time_limit = time_limit
        self.seed = seed

    @property
    def _cache(self) -> _Cache:
        """Solver models of this thread, kept across reports and optimiser instances."""
        cache = getattr(_THREAD, "cache", None)
        if cache is None:
            cache = _THREAD.cache = _Cache()
        return cache

    def _drop_cache(self) -> None:
        _THREAD.cache = _Cache()

    # -- solver models (kept across reports) ---------------------------------------------------
    def _lp(self, g_rows: Array, kmin: Array, kmax: Array, cost: Array) -> LinearModel:
        return self._cache.get("lp", g_rows, kmin, kmax, cost, lambda: _lp_model(g_rows, kmin, kmax))

    def _qp(self, g_rows: Array, kmin: Array, kmax: Array, cost: Array) -> LinearModel:
        r, n = g_rows.shape

        def build() -> LinearModel:
            model = LinearModel(np.zeros(n), g_rows, np.full(r, -INF), np.zeros(r), kmin, kmax)
            model.set_hessian_diagonal(2 * cost)
            return model

        return self._cache.get("qp", g_rows, kmin, kmax, cost, build)

    # -- stages --------------------------------------------------------------------------------
    def _lp_bound(self, g_rows: Array, g: Array, kmin: Array, kmax: Array, cost: Array,
                  clock: _Clock) -> tuple[float, Array, Array] | None:
        """t_LP, the LP point and the row weights y ≥ 0 of its dual (None: time limit reached)."""
        lp = self._lp(g_rows, kmin, kmax, cost)
        lp.set_row_bounds(np.full(g.size, -INF), g)
        cold = not lp.solved
        if cold and g.size > IPM_MIN_ROWS:
            lp.h.setOptionValue("solver", "ipm")
        res = lp.solve(clock.left())
        if cold:
            lp.h.setOptionValue("solver", "choose")
        if res.status not in ("optimal", "time_limit") and clock.left() > 0:  # one retry from scratch
            self._drop_cache()
            lp = self._lp(g_rows, kmin, kmax, cost)
            lp.set_row_bounds(np.full(g.size, -INF), g)
            res = lp.solve(clock.left())
        if res.status == "time_limit":
            return None
        if res.status != "optimal" or res.x is None or res.row_dual is None:
            raise SolverError(f"LP stage failed: HiGHS answered {res.detail!r}")
        return float(res.x[-1]), res.x[:-1], np.maximum(-res.row_dual, 0.0)

    def _rounded_rows_feasible(self, g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array,
                               clock: _Clock) -> str:
        """Whether G k ≤ b has a solution in the box (the kept LP with t fixed at 0)."""
        lp = self._lp(g_rows, kmin, kmax, cost)
        n = kmin.size
        lp.set_row_bounds(np.full(b.size, -INF), np.where(np.isfinite(b), b, INF))
        lp.set_col_bounds(np.array([n], dtype=np.int32), np.zeros(1), np.zeros(1))
        try:
            return lp.solve(max(clock.left(), 1e-3)).status
        finally:
            lp.set_col_bounds(np.array([n], dtype=np.int32), np.array([-INF]), np.array([INF]))

    def _max_margin_milp(self, g_rows: Array, g: Array, kmin: Array, kmax: Array, t_lo: float, t_hi: float,
                         start: Array | None, time_limit: float) -> Solve:
        r, n = g_rows.shape
        model = LinearModel(np.r_[np.zeros(n), -1.0], np.hstack([g_rows, np.ones((r, 1))]), np.full(r, -INF), g,
                            np.r_[kmin, t_lo], np.r_[kmax, t_hi], integer=np.r_[np.ones(n, bool), False])
        return model.solve(time_limit, None if start is None else np.r_[start, t_lo])

    def _continuous_least_norm(self, g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array,
                               clock: _Clock) -> tuple[str, tuple[Array, Array, Array, Array] | None]:
        """Least Σ c k² with G k ≤ b in the box: status and (point, multipliers of rows, lower, upper).

        Small problems by NNLS (:func:`~setupfix.optimize._grid.least_distance`, a fraction of a
        millisecond), large ones by HiGHS's QP solver on the kept model.
        """
        if g_rows.shape[0] + 2 * g_rows.shape[1] <= NNLS_MAX_ROWS:
            # the b-independent part of the NNLS system, kept with the solver models (the cache holds this
            # G and cost: the LP bound, which every solve starts with, set it)
            keep = np.isfinite(b)
            key = "nnls " + keep.tobytes().hex()
            system = self._cache.derived.get(key)
            if system is None or self._cache.g_rows is None or self._cache.g_rows.shape != g_rows.shape:
                system = self._cache.derived[key] = least_distance_system(g_rows[keep], cost)
            status, out = least_distance(g_rows, b, kmin, kmax, cost, system)  # type: ignore[arg-type]
            if status != "unknown":
                return status, out
        elif WORKING_SET_NNLS:
            status, out = least_distance_working_set(g_rows, b, kmin, kmax, cost, clock.deadline)
            if status != "unknown" or clock.left() <= 0:
                return status, out
        qp = self._qp(g_rows, kmin, kmax, cost)
        finite = np.where(np.isfinite(b), b, INF)
        qp.set_row_bounds(np.full(b.size, -INF), finite)
        res = qp.solve(max(clock.left(), 1e-3))
        if res.status != "optimal" or res.x is None or res.row_dual is None or res.col_dual is None:
            return res.status, None
        return "optimal", (res.x, np.maximum(-res.row_dual, 0.0), np.maximum(res.col_dual, 0.0),
                           np.maximum(-res.col_dual, 0.0))

    def _grid_least_norm(self, g_rows: Array, g: Array, b: Array, kmin: Array, kmax: Array, cost: Array,
                         t_star: float, incumbent: Array, cont: tuple[Array, Array, Array, Array] | None,
                         clock: _Clock, path: list[str], unit_box: bool | None = None,
                         box_share: float = BOX_SHARE) -> tuple[Array, bool, str, float]:
        """Least Σ c k² over grid points with every margin ≥ t_star; (k, proved, why not, lower bound).

        ``b`` are right-hand sides with {G k ≤ b} containing every such grid point (the
        rounded rows); ``cont`` the continuous least-norm solution over them, if known.
        The lower bound (0 when none is known) is certified: no such grid point has a
        smaller Σ c k².  ``unit_box``: stage 2 searched the unit box around the continuous
        point at these rows already (True: it found the incumbent there; False: it is empty).
        ``box_share``: share of the time left for each box MILP (larger when the grid-optimum
        stage was stopped: then a good incumbent matters more than a proof).
        """

        def norm(k: Array) -> float:
            return float(np.sum(cost * k**2))

        def ok(k: Array | None) -> bool:
            return k is not None and bool(grid_margins(g_rows, g, k) >= t_star - TOL)

        best = incumbent
        if cont is None:
            _, cont = self._continuous_least_norm(g_rows, b, kmin, kmax, cost, clock)
        if cont is None:  # no multipliers: the chord MILP over the whole box
            best = self._good_incumbent(g_rows, g, b, kmin, kmax, cost, t_star, best, None, clock)
            path.append("least norm: chords of k² (LP, then MILP)")
            found, proved, why, lower = self._chord_solve(g_rows, g, t_star, b, kmin, kmax, cost, best, best,
                                                          clock, clock.left() - DESCENT_RESERVE * self.time_limit)
            return self._finish(g_rows, b, cost, best if found is None else found, proved, why, lower, clock)
        k_c, lam_rows, lam_lo, lam_hi = cont
        rounded = np.clip(np.rint(k_c), kmin, kmax)
        if ok(rounded) and norm(rounded) < norm(best):
            best = rounded
        finite = np.isfinite(b)
        centre, q = lagrangian_ball(g_rows[finite], b[finite], kmin, kmax, cost, lam_rows[finite], lam_lo, lam_hi)
        def listed_least(limit: int) -> bool:  # the dual ellipsoid, listed; True: best is proven least
            nonlocal best
            found, proved, listed = ellipsoid_search(g_rows, g, t_star, centre, q, cost, kmin, kmax, norm(best),
                                                     limit, b, work_limit=ENUMERATION_WORK,
                                                     multipliers=(lam_rows, lam_lo, lam_hi))
            best = best if found is None else found
            if proved:
                path.append(f"least norm: {listed} grid points in the dual ellipsoid")
            return proved

        ellipsoid = kmin.size <= ELLIPSOID_MAX_REGISTERS  # beyond, the ellipsoid holds too many grid points
        # A short list only: most reports end here, and where the list would be long the box MILPs
        # below are cheaper (bench/exact_per_report.py).
        if ellipsoid and listed_least(ENUMERATION_LIMIT):
            return best, True, "", norm(best)
        best = self._good_incumbent(g_rows, g, b, kmin, kmax, cost, t_star, best, cont, clock)
        # A near-least incumbent: the least norm in the unit box around the continuous point (a MILP
        # with a linear objective), else in the box one step wider.
        floor_c = np.clip(np.floor(k_c), kmin, kmax)
        ceil_c = np.clip(np.ceil(k_c), kmin, kmax)
        # (stage 2 may have searched the unit box already: its point is the incumbent, or it is empty)
        for widen in (() if unit_box else (1.0,) if unit_box is False else (0.0, 1.0)):
            lo, hi = np.maximum(floor_c - widen, kmin), np.minimum(ceil_c + widen, kmax)
            res, k = box_least_norm(g_rows, b, lo, hi, cost, box_share * clock.left(), best, gap=INCUMBENT_GAP)
            if ok(k) and norm(k) < norm(best):  # type: ignore[arg-type]
                best = k  # type: ignore[assignment]
            path.append(f"least norm: box MILP ±{widen:g} around the continuous point ({res.status})")
            if k is not None or res.status not in ("infeasible", "optimal") or clock.left() <= 0:
                break
        box_lo, box_hi, lower = lagrangian_box(centre, q, cost, kmin, kmax, norm(best))
        if norm(best) <= _ceil_bound(lower, cost):
            path.append("least norm: the incumbent meets the Lagrangian bound")
            return best, True, "", norm(best)
        values = f"{np.mean(box_hi - box_lo + 1):.1f} values per register"
        if kmin.size <= BOX_PROOF_MAX_REGISTERS and float(np.sum(box_hi - box_lo)) <= BOX_PROOF_MAX_CHORDS:
            # few registers and a short box: every chord of the box at once, one MILP
            res, found = box_least_norm(g_rows, b, box_lo, box_hi, cost,
                                        clock.left() - DESCENT_RESERVE * self.time_limit, best, proof=True)
            path.append(f"least norm: box MILP in the Lagrangian box ({values}; {res.status})")
            found = found if ok(found) else None
            proved = res.status == "optimal" and found is not None
            why = "" if proved else ("time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
            chord_lower = res.dual_bound if np.isfinite(res.dual_bound) else 0.0
        else:
            path.append(f"least norm: chords of k² in the Lagrangian box ({values})")
            found, proved, why, chord_lower = self._chord_solve(
                g_rows, g, t_star, b, box_lo, box_hi, cost, best, k_c, clock,
                clock.left() - DESCENT_RESERVE * self.time_limit, proof=True)
        if found is not None and norm(found) > norm(best):
            found = None
        best = best if found is None else found
        # points outside the box have Σ c k² > f(best): the chord bound holds up to f(best)
        lower = max(lower, min(chord_lower, norm(best)))
        return self._finish(g_rows, b, cost, best, proved, why, lower, clock)

    def _finish(self, g_rows: Array, b: Array, cost: Array, best: Array, proved: bool, why: str, lower: float,
                clock: _Clock) -> tuple[Array, bool, str, float]:
        """A stopped least-norm proof: coordinate descent on its best point (the norm never grows)."""
        if not proved:
            best = descend(g_rows, b, best, cost, time.perf_counter() + max(clock.left(), 0.0)
                           + DESCENT_RESERVE * self.time_limit / 2)
        return best, proved, why, lower

    def _good_incumbent(self, g_rows: Array, g: Array, b: Array, kmin: Array, kmax: Array, cost: Array,
                        t_star: float, best: Array, cont: tuple[Array, Array, Array, Array] | None,
                        clock: _Clock) -> Array:
        """A small feasible grid point before the MILPs (heuristics; the MILPs prove or improve it).

        * Safe rounding: the continuous least-norm point of the rows tightened by half their
          l1 norm rounds to a point that meets the original rows (each coordinate moves ≤ ½).
        * The segment from the incumbent to the continuous least-norm point is feasible; the
          rounded point farthest along it that stays feasible.
        * :func:`~setupfix.optimize._least_norm.descend`: coordinate moves towards 0 while feasible.
        """
        def f(k: Array) -> float:
            return float(np.sum(cost * k**2))

        def ok(k: Array) -> bool:
            return bool(grid_margins(g_rows, g, k) >= t_star - TOL)

        out = None
        if g_rows.shape[0] + 2 * kmin.size <= NNLS_MAX_ROWS:  # one more QP only where QPs are cheap
            safe = b - 0.5 * np.sum(np.abs(g_rows), axis=1)
            _, out = self._continuous_least_norm(g_rows, safe, kmin, kmax, cost, clock)
        if out is not None:
            k = np.clip(np.rint(out[0]), kmin, kmax)
            if ok(k) and f(k) < f(best):
                best = k
        if cont is not None:
            lo, hi = 0.0, 1.0
            for _ in range(12):
                mid = (lo + hi) / 2
                k = np.clip(np.rint(best + mid * (cont[0] - best)), kmin, kmax)
                if ok(k):
                    lo = mid
                    if f(k) < f(best):
                        best = k
                else:
                    hi = mid
        return descend(g_rows, b, best, cost, time.perf_counter() + 0.03 * max(clock.left(), 0.0))

    def _chord_solve(self, g_rows: Array, g: Array, level: float, b: Array, kmin: Array, kmax: Array,
                     cost: Array, best: Array | None, k_cont: Array, clock: _Clock, time_limit: float,
                     proof: bool = False) -> tuple[Array | None, bool, str, float]:
        """:func:`~setupfix.optimize._least_norm.chord_least_norm` for at most ``time_limit`` seconds."""
        deadline = min(clock.deadline, time.perf_counter() + max(time_limit, 0.0))
        return chord_least_norm(g_rows, g, level, b, kmin, kmax, cost, best, k_cont, deadline, proof)

    def _triaged(self, problem: CorrectionProblem, g_rows: Array, g: Array, kmin: Array, kmax: Array, cost: Array,
                 k_start: Array, clock: _Clock, path: list[str], notes: list[Note], calls: int,
                 bound: float) -> OptimizeResult:
        """No correction brings every dimension into tolerance: :func:`~setupfix.optimize._triage.triage`."""
        from setupfix.optimize._triage import triage

        upper_ok, lower_ok = np.isfinite(problem.upper), np.isfinite(problem.lower)
        row_dim = np.r_[np.flatnonzero(upper_ok), np.flatnonzero(lower_ok)]
        m = len(problem.dimension_ids)
        k, proved, why, done = triage(g_rows, g, row_dim, m, kmin, kmax, cost, clock.deadline, k_start)
        clock.lap("triage")
        path.append("triage: " + ", ".join(done) if done else "triage")
        x = np.zeros(problem.n_registers)
        x[problem.free] = k * problem.resolution
        margins = problem.margins(x)
        quantum = QUANTUM * problem.resolution
        given_up = tuple(d for d, v in zip(problem.dimension_ids, margins) if v < -quantum)
        kept = margins >= -quantum
        low = margins[kept].min() if kept.any() else 0.0
        binding = tuple(d for d, v, ok in zip(problem.dimension_ids, margins, kept)
                        if ok and v <= low + problem.resolution / 4)
        message = (f"no correction within the register limits brings every dimension into tolerance: "
                   f"{len(given_up)} dimension(s) given up ({', '.join(given_up)}) need the NC program or the "
                   "process, not the setup; the other dimensions are kept in tolerance with the largest error "
                   "budget and the smallest correction")
        notes.append(Note(message, kind="solver"))
        status = "optimal"
        extra: dict[str, object] = {"stages": dict(clock.stages), "path": "; ".join(path)}
        if not proved:
            status = "time_limit" if "time limit" in why else "solver_error"
            notes.append(Note(f"triage not proved ({why})", kind="solver"))
            message += f"; not proved ({why})"
            extra["stopped"] = {"stage": "triage", "reason": why}
        # guard off: triage trades the error budget of the hopeless dimensions on purpose, and says so
        result = make_result(problem, x, optimizer=self.name, evaluations=calls + 3,
                             seconds=time.perf_counter() - clock.start, status=status, bound=bound,
                             message=message, binding=binding, guard=False)
        result.extra.update(extra)
        result.given_up = given_up
        result.notes = tuple(notes)
        return result

    # -- driver --------------------------------------------------------------------------------
    def solve(self, problem: CorrectionProblem) -> OptimizeResult:
        with _blas_single_thread():  # small solves: BLAS threads only contend
            return self._solve(problem)

    def _solve(self, problem: CorrectionProblem) -> OptimizeResult:
        clock = _Clock(self.time_limit)
        free = problem.free
        x = np.zeros(problem.n_registers)
        g_rows, g = margin_rows(problem)
        if free.sum() == 0 or g.size == 0:
            return make_result(problem, x, optimizer=self.name, evaluations=0,
                               seconds=time.perf_counter() - clock.start, status="optimal",
                               bound=problem.margin_before,
                               message="nothing can be corrected: every register is fixed or no limit applies")
        kmin = problem.kmin[free].astype(float)
        kmax = problem.kmax[free].astype(float)
        cost = problem.cost[free]
        notes: list[Note] = []
        path: list[str] = []
        calls = 1
        lp = self._lp_bound(g_rows, g, kmin, kmax, cost, clock)
        if lp is None:  # not even the LP bound within the limit: no correction, and says so
            text = (f"the LP bound was not proved within the time limit ({self.time_limit:g} s): no correction "
                    "is recommended; allow more time (--time-limit)")
            result = make_result(problem, x, optimizer=self.name, evaluations=1,
                                 seconds=time.perf_counter() - clock.start, status="time_limit", message=text)
            result.notes = (Note(text, kind="solver"),)
            result.extra.update({"stopped": {"stage": "lp bound", "reason": "time limit"}, "path": "lp bound: time limit"})
            return result
        t_lp, k_lp, y = lp
        binding = _rows_to_dimensions(problem, y > 1e-9)
        bound = t_lp * problem.resolution
        clock.lap("lp bound")

        if not self.grid:
            _, cont = self._continuous_least_norm(g_rows, g - t_lp + 1e-8, kmin, kmax, cost, clock)
            x[free] = (k_lp if cont is None else cont[0]) * problem.resolution
            clock.lap("least norm")
            return make_result(problem, x, optimizer=self.name, evaluations=calls + 1,
                               seconds=time.perf_counter() - clock.start, status="optimal", bound=bound,
                               binding=binding)

        # Stage 2: grid optimum.
        d, pairs = self._cache.structure(g_rows, kmin, kmax, cost)
        zero = ~np.any(g_rows != 0, axis=1)
        upper = min(dual_bound(g_rows, g, y, kmin, kmax), pair_bound(g_rows, g, kmin, kmax, pairs))
        k_best = np.clip(np.rint(k_lp), kmin, kmax)
        t_best = float(grid_margins(g_rows, g, k_best))
        t_zero = float(grid_margins(g_rows, g, np.zeros_like(k_best)))
        if t_zero >= t_best:  # no correction at all is a grid point too
            k_best, t_best = np.zeros_like(k_best), t_zero
        stopped: tuple[str, str] | None = None
        cont = None
        placeholder = False  # cont holds no least-norm point (large problems whose QP failed)
        unit_box: tuple[Array, bool] | None = None  # rows whose unit box stage 2 searched, and if it had a point
        least_norm_done: Array | None = None  # rows at which the least norm is already proved
        least_listed = 0
        n_free = int(kmin.size)
        small = g_rows.shape[0] + 2 * n_free <= NNLS_MAX_ROWS
        stage2_end = clock.deadline - LEAST_NORM_SHARE * self.time_limit

        def stage2_left() -> float:  # the grid-optimum stage leaves a share of the limit to the least norm
            return stage2_end - time.perf_counter()

        level = upper
        all_integer = bool(np.all((d > 0) | zero))
        if upper < -TOL:
            path.append("grid optimum: the bound is below 0 (no correction brings every dimension into tolerance)")
        elif t_best >= upper - TOL:
            path.append("grid optimum: rounded LP point attains the bound")
        else:
            proved = False
            for _ in range(LEVEL_STEPS):
                if stage2_left() <= 0:
                    break
                b = rounded_rhs(g, d, zero, level)
                calls += 1
                if small:
                    status, cont = self._continuous_least_norm(g_rows, b, kmin, kmax, cost, clock)
                else:  # large: whether the rounded rows are feasible (an LP), then their least-norm point
                    status, cont = self._rounded_rows_feasible(g_rows, b, kmin, kmax, cost, clock), None
                    if status == "optimal":
                        _, cont = self._continuous_least_norm(g_rows, b, kmin, kmax, cost, clock)
                        placeholder = cont is None
                        if cont is None:
                            cont = (k_best, np.zeros(g.size), np.zeros(n_free), np.zeros(n_free))
                if cont is None:
                    if status != "infeasible" or not all_integer:
                        break
                    level = next_level(g, d, b)  # nothing on the grid above this level
                    if t_best >= level - TOL:
                        path.append("grid optimum: rounded LP point attains the rounded-rows bound")
                        proved = True
                        break
                    continue
                k = np.clip(np.rint(cont[0]), kmin, kmax)
                t_k = float(grid_margins(g_rows, g, k))
                if t_k > t_best:
                    k_best, t_best = k, t_k
                if t_best >= level - TOL:
                    path.append("grid optimum: least-norm point of the rounded rows attains the bound")
                    proved = True
                    break
                # A grid point at the bound near the continuous one: growing ellipsoids, a bounded list.
                found = None
                if small:
                    finite = np.isfinite(b)
                    centre, q = lagrangian_ball(g_rows[finite], b[finite], kmin, kmax, cost, cont[1][finite],
                                                cont[2], cont[3])
                    found, least, listed = ellipsoid_search(g_rows, g, level, centre, q, cost, kmin, kmax, np.inf,
                                                            SEARCH_LIMIT, b, work_limit=SEARCH_WORK,
                                                            multipliers=(cont[1], cont[2], cont[3]))
                    if found is not None and least:  # the least norm at the bound: stage 3 has nothing to do
                        least_norm_done = b.copy()
                        least_listed = listed
                    elif found is None and least and all_integer:  # the whole box listed: no grid point at level
                        path.append(f"grid optimum: no grid point at {level:.4g} steps (the whole box listed)")
                        level = next_level(g, d, b)
                        cont = None
                        if t_best >= level - TOL:
                            path.append("grid optimum: best point attains the bound lowered by infeasible levels")
                            proved = True
                            break
                        continue
                elif not placeholder and stage2_left() > 0:  # large: the least norm in the unit box around it
                    res_box, found = box_least_norm(g_rows, b, np.clip(np.floor(cont[0]), kmin, kmax),
                                                    np.clip(np.ceil(cont[0]), kmin, kmax), cost,
                                                    stage2_left() * MILP_SHARE / 2, gap=INCUMBENT_GAP)
                    calls += 1
                    path.append(f"grid optimum: box MILP ±0 around the rounded rows' least-norm point "
                                f"({res_box.status})")
                    if found is not None and float(grid_margins(g_rows, g, found)) < level - TOL:
                        found = None
                    if found is not None or res_box.status == "infeasible":
                        unit_box = (b.copy(), found is not None)  # the unit box is settled at these rows
                    if found is None and res_box.status == "infeasible" and stage2_left() > 0:
                        # any point one step wider (a feasibility MILP)
                        fin = np.isfinite(b)
                        lo = np.clip(np.floor(cont[0]) - 1, kmin, kmax)
                        hi = np.clip(np.ceil(cont[0]) + 1, kmin, kmax)
                        wide = LinearModel(np.zeros(n_free), g_rows[fin], np.full(int(fin.sum()), -INF), b[fin], lo,
                                           hi, integer=np.ones(n_free, bool)).solve(stage2_left() * MILP_SHARE / 2)
                        calls += 1
                        path.append(f"grid optimum: feasibility MILP ±1 around it ({wide.status})")
                        if wide.x is not None:
                            found = np.clip(np.rint(wide.x), lo, hi)
                            if float(grid_margins(g_rows, g, found)) < level - TOL:
                                found = None
                if found is not None:
                    k_best, t_best = found, float(grid_margins(g_rows, g, found))
                    path.append("grid optimum: a grid point near the rounded rows' least-norm point attains the "
                                "bound")
                    proved = True
                    break
                # A feasibility MILP on the rounded rows: a point proves the bound is reached; a proof
                # of infeasibility lowers the bound to the next level (integer rows only).
                if stage2_left() <= 0:
                    break
                fin = np.isfinite(b)
                feas = LinearModel(np.zeros(n_free), g_rows[fin], np.full(int(fin.sum()), -INF), b[fin], kmin, kmax,
                                   integer=np.ones(n_free, bool)).solve(stage2_left() * MILP_SHARE)
                calls += 1
                path.append(f"grid optimum: feasibility MILP at {level:.4g} steps ({feas.status}, {feas.seconds:.2f} s)")
                if feas.x is not None:
                    k = np.clip(np.rint(feas.x), kmin, kmax)
                    t_k = float(grid_margins(g_rows, g, k))
                    if t_k > t_best:
                        k_best, t_best = k, t_k
                    if t_best >= level - TOL:
                        path.append("grid optimum: a feasibility MILP on the rounded rows reaches the bound")
                        proved = True
                        cont = cont if t_best <= level + TOL else None
                        break
                if feas.status == "infeasible" and all_integer:
                    level = next_level(g, d, b)
                    cont = None
                    if t_best >= level - TOL:
                        path.append("grid optimum: best point attains the bound lowered by infeasible levels")
                        proved = True
                        break
                    continue
                break
            upper = min(upper, level)
            if placeholder:
                cont = None
            if not proved and stage2_left() <= 0:  # its share of the limit is spent: no MILP
                cont = None
                path.append("grid optimum: its share of the time limit spent before the MILP")
                stopped = ("grid optimum", "time limit")
            elif not proved:
                cont = None
                calls += 1
                res = self._max_margin_milp(g_rows, g, kmin, kmax, t_best, upper, k_best, stage2_left())
                if res.status == "error":
                    notes.append(Note(f"HiGHS answered {res.detail!r} on the grid MILP bracketed by the best "
                                      f"grid point ({t_best:.4g}) and the bound ({upper:.4g} steps); retried "
                                      "without the lower bracket", kind="solver"))
                    calls += 1
                    res = self._max_margin_milp(g_rows, g, kmin, kmax, -INF, upper, None, stage2_left())
                if res.x is not None:
                    k = np.clip(np.rint(res.x[:-1]), kmin, kmax)
                    t_k = float(grid_margins(g_rows, g, k))
                    if t_k > t_best:
                        k_best, t_best = k, t_k
                path.append(f"grid optimum: MILP ({res.status})")
                if res.status != "optimal":
                    stopped = ("grid optimum", "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
        clock.lap("grid optimum")
        if upper < -TOL or (stopped is None and t_best < -TOL):
            return self._triaged(problem, g_rows, g, kmin, kmax, cost, k_best, clock, path, notes, calls, bound)

        # Stage 3: least norm at the error budget reached (also when stage 2 was stopped).
        b = rounded_rhs(g, d, zero, t_best)
        norm_lower = 0.0
        if least_norm_done is not None and np.array_equal(b, least_norm_done):
            proved_norm, why = True, ""
            path.append(f"least norm: {least_listed} grid points in the dual ellipsoid (listed with the grid optimum)")
        else:
            calls += 1
            if cont is not None and not np.array_equal(b, rounded_rhs(g, d, zero, level)):
                cont = None
            k_best, proved_norm, why, norm_lower = self._grid_least_norm(
                g_rows, g, b, kmin, kmax, cost, t_best, k_best, cont, clock, path,
                unit_box=None if unit_box is None or not np.array_equal(b, unit_box[0]) else unit_box[1],
                box_share=BOX_SHARE if stopped is None else STOPPED_BOX_SHARE)
        if not proved_norm and stopped is None:
            stopped = ("least norm", why)
        clock.lap("least norm")

        x[free] = k_best * problem.resolution
        status, message = "optimal", None
        extra: dict[str, object] = {"stages": dict(clock.stages), "path": "; ".join(path)}
        if stopped is not None:
            stage, why = stopped
            status = "time_limit" if why == "time limit" else "solver_error"
            if stage == "grid optimum":
                message = (f"grid optimum not proved ({why} in the grid-optimum stage); the least-norm correction "
                           f"at the best error budget found is given; the continuous bound is {bound:.4f}")
            else:
                message = (f"grid optimum proved, least norm not proved ({why} in the least-norm stage); the "
                           "smallest correction found at the optimum is given")
            if not proved_norm:
                ratio = lower_bound_ratio(float(np.sum(cost * k_best**2)), norm_lower)
                extra["norm_ratio_max"] = ratio
                message += (f", at most {ratio:.3f}× the least norm (certified)" if np.isfinite(ratio)
                            else ", with no bound on how far it is from the least norm")
            notes.append(Note(message, kind="solver"))
            extra["stopped"] = {"stage": stage, "reason": why}
        result = make_result(problem, x, optimizer=self.name, evaluations=calls,
                             seconds=time.perf_counter() - clock.start, status=status, bound=bound,
                             message=message, binding=binding)
        result.extra.update(extra)
        result.notes = tuple(notes)
        return result
