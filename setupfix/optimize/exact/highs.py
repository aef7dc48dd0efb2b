"""Thin layer over HiGHS's own Python interface (highspy) for the exact optimiser.

Why highspy and not scipy's ``linprog``/``milp``: scipy rebuilds the model and re-validates every
option on each call; highspy keeps it, so a solve can change only row bounds or add rows (lazy cuts)
between runs.  Each run starts from a cleared solver (no basis or incumbent of an earlier run: the
answer depends on this model and start only).  A run is limited by **work**, not time
(:mod:`setupfix.optimize.exact.work`): its allowance in work units becomes HiGHS's iteration limits
(simplex, IPM, QP) and, for a MIP, its node limit; what the run did (iterations, nodes) is charged
to the solve's meter, so the same model gives the same answer under any load (no model outlives
one solve: :class:`~setupfix.optimize.exact.session.Session`).

Nothing HiGHS answers is taken on trust (:meth:`LinearModel.solve`): its point is checked
against the model — rows, bounds and integrality to :data:`FEASIBILITY_TOL`, its objective
against the value HiGHS reports and, for an "optimal" MIP, against the dual bound.  HiGHS 1.16
given a start has answered "optimal" with the start itself; such an answer is solved again
without the start, and an answer that still fails is an ``error``, never ``optimal``.  The
wall-clock guard against a hang (the solve's meter's ``guard``) is enforced by HiGHS's interrupt
callbacks (MIP, simplex, IPM, QP) and by HiGHS's own ``time_limit``; and every MIP runs without
the RINS and RENS sub-searches, which read neither the callbacks nor, reliably, the limits.

Every solver object is silent (nothing may reach stdout, which carries ``--json``) and single-threaded
(the solves are small; a batch runs its own workers).  The private ``_Highs`` class is used because the
public ``Highs`` prints a banner on stdout and installs callbacks we do not use.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt
from highspy._core import (
    HessianFormat,
    HighsModelStatus,
    HighsStatus,
    HighsVarType,
    MatrixFormat,
    ObjSense,
    _Highs,
    cb,
    kHighsInf,
)
from scipy.sparse import csc_array, vstack

from setupfix.optimize.exact.work import current, mip_root_work, model_size, run_limits, run_work, wall

__all__ = ["FEASIBILITY_TOL", "INF", "Colwise", "LinearModel", "Solve"]

Array = npt.NDArray[np.float64]
INF = float(kHighsInf)
#: A point HiGHS returns must meet each row, bound and integrality to this (relative to the row's
#: size: 1 + |bound| + Σ|a_ij x_j|), and its objective must equal the one HiGHS reports to it.
FEASIBILITY_TOL = 1e-6
#: HiGHS's own ``mip_abs_gap``: an "optimal" MIP's objective may exceed its dual bound by this.
MIP_ABS_GAP = 1e-6
#: Models up to this many matrix elements are checked with a dense copy of the matrix.
DENSE_CHECK_ELEMENTS = 20_000
#: Interrupts checked against the wall-clock guard (HiGHS reads ``time_limit`` between cut rounds, not in sub-searches).
_INTERRUPTS = (
    cb.HighsCallbackType.kCallbackMipInterrupt,
    cb.HighsCallbackType.kCallbackSimplexInterrupt,
    cb.HighsCallbackType.kCallbackIpmInterrupt,
    cb.HighsCallbackType.kHighsCallbackQpInterrupt,  # type: ignore[attr-defined]  # not in the stubs
)
#: Model statuses that are answers (optimal, proven infeasible, stopped at a limit with or without a point:
#: "time_limit" whether the work limits or the wall-clock guard stopped it; the meter tells which).
_STATUS_NAMES = {
    HighsModelStatus.kOptimal: "optimal",
    HighsModelStatus.kInfeasible: "infeasible",
    HighsModelStatus.kUnboundedOrInfeasible: "infeasible",
    HighsModelStatus.kUnbounded: "unbounded",
    HighsModelStatus.kTimeLimit: "time_limit",
    HighsModelStatus.kIterationLimit: "time_limit",
    HighsModelStatus.kSolutionLimit: "time_limit",  # the node limit (``mip_max_nodes``)
    HighsModelStatus.kInterrupt: "time_limit",
}


@dataclass
class Solve:
    """Outcome of one HiGHS run.

    Attributes
    ----------
    status : str
        ``optimal``, ``infeasible``, ``unbounded``, ``time_limit`` or ``error`` (anything else HiGHS
        answers, e.g. "Solve error"); ``detail`` gives HiGHS's own words.
    x : ndarray of shape (n_cols,) or None; objective, dual_bound : float
        Primal point (when HiGHS has one), its objective (nan without) and the best bound proved.
    row_dual, col_dual : ndarray of shape (n_rows,) / (n_cols,) or None
        Duals of an LP or QP (HiGHS's signs: for a minimisation, ≤ 0 on a row or column at its upper
        bound, ≥ 0 at its lower bound).
    seconds : float
        Work units of the run (with its re-solve, if the first answer failed the check): iterations
        and nodes × ``node_work`` (:mod:`setupfix.optimize.exact.work`), never wall time.
    """

    status: str
    detail: str
    x: Array | None
    objective: float
    dual_bound: float
    row_dual: Array | None
    col_dual: Array | None
    seconds: float


def new_solver() -> _Highs:
    """A silent, single-threaded HiGHS instance."""
    h = _Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    return h


@dataclass(frozen=True)
class Colwise:
    """A constraint matrix in HiGHS's column-wise form (pure data: may be shared between models).

    Attributes
    ----------
    n_rows, n_cols : int
    start : ndarray of int32, shape (n_cols + 1,)
        Where each column's entries start in ``index`` (row of each entry) and ``value``, shape (nnz,).
    """

    n_rows: int
    n_cols: int
    start: npt.NDArray[np.int32]
    index: npt.NDArray[np.int32]
    value: Array
    cache: dict[str, Array] = field(default_factory=dict, compare=False, repr=False)  # :meth:`dense`

    def dense(self) -> tuple[Array, Array]:
        """The matrix and |matrix| as dense read-only arrays, built once (shared by every model on it)."""
        if "dense" not in self.cache:  # frozen before it is shared (threads may build it at once: equal copies)
            a = csc_array((self.value, self.index, self.start), shape=(self.n_rows, self.n_cols)).toarray()
            b = np.abs(a)
            a.flags.writeable = b.flags.writeable = False
            self.cache["abs"], self.cache["dense"] = b, a
        return self.cache["dense"], self.cache["abs"]

    @classmethod
    def of(cls, a: object) -> Colwise:
        """From a dense array of shape (n_rows, n_cols) or any scipy sparse array."""
        if isinstance(a, np.ndarray):  # dense (small models): column-wise arrays by numpy, no scipy round trip
            at = np.asarray(a, dtype=float).T
            nonzero = at != 0
            start = np.r_[0, np.cumsum(np.sum(nonzero, axis=1))]
            return cls(
                int(at.shape[1]),
                int(at.shape[0]),
                start.astype(np.int32),
                np.nonzero(nonzero)[1].astype(np.int32),
                at[nonzero],
            )
        mat = csc_array(a)
        return cls(
            int(mat.shape[0]),
            int(mat.shape[1]),
            mat.indptr.astype(np.int32),
            mat.indices.astype(np.int32),
            np.asarray(mat.data, dtype=float),
        )


class LinearModel:
    """One LP/MILP ``min cᵀx, row_lo ≤ A x ≤ row_hi, col_lo ≤ x ≤ col_hi`` kept in HiGHS.

    Parameters
    ----------
    c : ndarray of shape (n_cols,)
    a : ndarray of shape (n_rows, n_cols), scipy sparse array or Colwise
    row_lo, row_hi : ndarray of shape (n_rows,)
    col_lo, col_hi : ndarray of shape (n_cols,)
    integer : ndarray of bool, shape (n_cols,), optional
        Integer columns (a MILP); default all continuous.
    limit_slack : float, default=0.0
        Work units added to each run's allowance beyond what :meth:`solve` is given.

    The model keeps its own copy of the data so that every answer can be checked
    (:meth:`check`).
    """

    def __init__(
        self,
        c: Array,
        a: object,
        row_lo: Array,
        row_hi: Array,
        col_lo: Array,
        col_hi: Array,
        integer: npt.NDArray[np.bool_] | None = None,
        limit_slack: float = 0.0,
    ) -> None:
        self.limit_slack = float(limit_slack)
        mat = a if isinstance(a, Colwise) else Colwise.of(a)
        self.n_cols, self.n_rows = mat.n_cols, mat.n_rows
        self.is_mip = integer is not None and bool(np.any(integer))
        kinds = np.zeros(self.n_cols, dtype=np.int32) if integer is None else np.asarray(integer, dtype=np.int32)
        self._c = np.asarray(c, dtype=float)
        self._mat, self._csc = mat, None  # A column-wise; as a scipy array only where check() needs it
        self._abs_a: Array | csc_array | None = None  # |A|, for the rows' sizes in check()
        self._dense: Array | None = None  # A as a dense array, where small (check() is then ~µs)
        if isinstance(a, np.ndarray) and a.size <= DENSE_CHECK_ELEMENTS:
            self._dense = np.asarray(a, dtype=float)
        self._finite: tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]] | None = None
        self._row_lo, self._row_hi = np.asarray(row_lo, dtype=float).copy(), np.asarray(row_hi, dtype=float).copy()
        self._col_lo, self._col_hi = np.asarray(col_lo, dtype=float).copy(), np.asarray(col_hi, dtype=float).copy()
        self._integer = kinds.astype(bool)
        self._hessian: Array | None = None
        self._gap, self._warm = 0.0, False
        self.h = new_solver()
        if self.is_mip:
            self._mip_options()
        # the arrays go to HiGHS as they are (column-wise, minimise, no offset; integrality 0/1 per column)
        self._check(
            self.h.passModel(  # the array overload
                self.n_cols,
                self.n_rows,
                int(mat.value.size),
                int(MatrixFormat.kColwise),
                int(ObjSense.kMinimize),
                0.0,
                self._c,
                self._col_lo,
                self._col_hi,
                self._row_lo,
                self._row_hi,
                mat.start,
                mat.index,
                mat.value,
                kinds,
            ),
            "passModel",
        )
        self._rows = np.arange(self.n_rows, dtype=np.int32)
        self._cols = np.arange(self.n_cols, dtype=np.int32)
        self._deadline = [np.inf]  # read by the interrupt callback
        self._check(self.h.setCallback(_interrupt, self._deadline), "setCallback")
        for kind in _INTERRUPTS:
            self._check(self.h.startCallback(kind), "startCallback")

    @staticmethod
    def _check(status: HighsStatus, what: str) -> None:
        if status == HighsStatus.kError:
            raise RuntimeError(f"HiGHS refused {what}")

    def _mip_options(self) -> None:
        self.h.setOptionValue("mip_rel_gap", 0.0)
        for name in ("mip_heuristic_run_rins", "mip_heuristic_run_rens"):  # their sub-MIPs ignore the limits
            self.h.setOptionValue(name, False)

    def set_hessian_diagonal(self, diag: Array) -> None:
        """Make the objective cᵀx + ½ Σ diag_i x_i² (a convex QP; continuous columns only)."""
        diag = np.asarray(diag, dtype=float)
        idx = np.arange(diag.size, dtype=np.int32)
        self._check(
            self.h.passHessian(diag.size, diag.size, int(HessianFormat.kTriangular), idx, idx.copy(), diag),
            "passHessian",
        )
        self._hessian = np.r_[diag, np.zeros(self.n_cols - diag.size)]

    def make_integer(self, cols: npt.NDArray[np.intp]) -> None:
        """Turn columns into integer ones (the LP becomes a MILP, solved to a zero gap)."""
        cols = np.asarray(cols, dtype=np.int32)
        types = np.array([HighsVarType.kInteger] * cols.size)
        self._check(self.h.changeColsIntegrality(cols.size, cols, types), "changeColsIntegrality")
        self._integer[cols] = True
        if not self.is_mip:
            self.is_mip = True
            self._mip_options()

    def keep_basis(self) -> None:
        """LP runs from the last basis, no presolve: faster, but the vertex may depend on earlier runs (one solve's)."""
        self._warm = self.h.setOptionValue("presolve", "off") == HighsStatus.kOk

    def skip_presolve(self) -> None:
        """No presolve: the leximin count MILPs take ~1.5× less CPU without it (``bench/leximin_counts.py``)."""
        self.h.setOptionValue("presolve", "off")

    def set_gap(self, gap: float) -> None:
        """Let HiGHS stop a MIP at this relative gap (an incumbent is wanted, not a proof)."""
        self._gap = float(gap)
        self.h.setOptionValue("mip_rel_gap", self._gap)

    def prefer_proof(self) -> None:
        """Pseudo-costs without strong-branching reliability: about half the time to prove shop-scale least norms."""
        self.h.setOptionValue("mip_pscost_minreliable", 0)

    def set_row_bounds(self, lo: Array, hi: Array) -> None:
        """Change every row's bounds (the deviations of a new report enter here)."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self._check(
            self.h.changeRowsBounds(  # type: ignore[attr-defined]  # in highspy, not its stubs
                self.n_rows, self._rows, lo, hi
            ),
            "changeRowsBounds",
        )
        self._row_lo, self._row_hi = lo.copy(), hi.copy()
        self._finite = None

    def set_col_bounds(self, cols: npt.NDArray[np.int32], lo: Array, hi: Array) -> None:
        cols = np.asarray(cols, dtype=np.int32)
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self._check(self.h.changeColsBounds(cols.size, cols, lo, hi), "changeColsBounds")
        self._col_lo[cols], self._col_hi[cols] = lo, hi

    def set_column(self, col: int, rows: npt.NDArray[np.intp], values: Array) -> None:
        """Set column ``col``'s coefficients in ``rows`` (in HiGHS and in the copy :meth:`check` reads)."""
        a, rows, values = self._a.tolil(), np.asarray(rows, dtype=int), np.asarray(values, dtype=float)
        for j, v in zip(rows, values, strict=True):
            self._check(self.h.changeCoeff(int(j), int(col), float(v)), "changeCoeff")
        a[rows, int(col)] = values
        self._csc, self._abs_a, self._dense = csc_array(a), None, None

    def set_costs(self, cols: npt.NDArray[np.int32], costs: Array) -> None:
        """Change the linear costs of ``cols`` (in HiGHS and in the copy :meth:`check` reads)."""
        cols, self._c = np.asarray(cols, dtype=np.int32), self._c.copy()
        self._c[cols] = np.asarray(costs, dtype=float)
        self._check(self.h.changeColsCost(cols.size, cols, self._c[cols]), "changeColsCost")

    def add_rows(self, a: object, lo: Array, hi: Array) -> None:
        """Append rows (lazy cuts); ``a`` has shape (k, n_cols)."""
        mat = csc_array(a).tocsr()
        k = int(mat.shape[0])
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        self._check(
            self.h.addRows(
                k,
                lo,
                hi,
                mat.nnz,
                mat.indptr[:-1].astype(np.int32),
                mat.indices.astype(np.int32),
                mat.data.astype(float),
            ),
            "addRows",
        )
        self._csc = csc_array(vstack([self._a, mat]))
        self._abs_a = self._dense = None
        self._finite = None
        self._row_lo, self._row_hi = np.r_[self._row_lo, lo], np.r_[self._row_hi, hi]
        self.n_rows += k
        self._rows = np.arange(self.n_rows, dtype=np.int32)

    @property
    def _a(self) -> csc_array:
        if self._csc is None:
            mat = self._mat
            self._csc = csc_array((mat.value, mat.index, mat.start), shape=(mat.n_rows, mat.n_cols))
        return self._csc

    def _matrix(self) -> Array | csc_array:
        if self._dense is None and self.n_rows * self.n_cols <= DENSE_CHECK_ELEMENTS:
            if self._csc is None:  # the matrix as passed in (maybe shared): its dense copy is kept with it
                self._dense, self._abs_a = self._mat.dense()
            else:
                self._dense = self._a.toarray()
        return self._a if self._dense is None else self._dense

    def _row_finite(self) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        self._finite = self._finite or (np.isfinite(self._row_lo), np.isfinite(self._row_hi))
        return self._finite

    def _abs(self) -> Array | csc_array:
        if self._abs_a is None:
            self._abs_a = abs(self._matrix())
        return self._abs_a

    def value(self, x: Array) -> float:
        """The model's objective at ``x``."""
        quad = 0.0 if self._hessian is None else 0.5 * float(np.sum(self._hessian * x * x))
        return float(self._c @ x) + quad

    def check(self, x: Array | None, objective: float, dual_bound: float, status: str) -> str:
        """Why HiGHS's answer (point, objective, dual bound, status) contradicts the model; empty if it does not.

        Rows, bounds and integrality are checked to :data:`FEASIBILITY_TOL` (relative); the
        point's objective must equal ``objective``; an ``optimal`` MIP's objective must lie
        within the gap allowed (``mip_rel_gap``, ``mip_abs_gap``) above ``dual_bound``.
        """
        if x is None or status not in ("optimal", "time_limit", "feasible"):
            return "optimal without a point" if status == "optimal" else ""
        tol = FEASIBILITY_TOL
        a = self._matrix()
        act = a @ x
        size = 1.0 + self._abs() @ np.abs(x)
        lo, hi = self._row_lo, self._row_hi
        lo_ok, hi_ok = self._row_finite()
        with np.errstate(invalid="ignore"):  # an infinite bound (left out) gives inf/inf
            worst = max(
                float(np.max(((lo - act) / (size + np.abs(lo)))[lo_ok], initial=0.0)),
                float(np.max(((act - hi) / (size + np.abs(hi)))[hi_ok], initial=0.0)),
            )
        if worst > tol:
            return f"a row is violated by {worst:.2g} (relative)"
        scale = 1.0 + np.abs(x)
        if np.any(self._col_lo - x > tol * scale) or np.any(x - self._col_hi > tol * scale):
            return "a column is outside its bounds"
        if self.is_mip and np.any(np.abs(x - np.rint(x))[self._integer] > 10 * tol):
            return "an integer column is fractional"
        val = self.value(x)
        obj_tol = tol * (1.0 + abs(val) + float(np.abs(self._c) @ np.abs(x)))
        if not abs(val - objective) <= obj_tol:
            return f"its point's objective is {val:.10g}, not the {objective:.10g} reported"
        if status == "optimal" and self.is_mip:
            allowed = max(MIP_ABS_GAP, self._gap * abs(objective)) + obj_tol
            if not (objective - dual_bound <= allowed and dual_bound - objective <= obj_tol):
                return f"'optimal' with objective {objective:.10g} and dual bound {dual_bound:.10g}"
        return ""

    def solve(self, time_limit: float, start: Array | None = None) -> Solve:
        """Run HiGHS for at most ``time_limit`` work units (optionally from a feasible ``start``), checked.

        ``time_limit`` is an allowance of work (:func:`~setupfix.optimize.exact.work.run_limits`), not
        seconds: the name is the stages' (their shares of the solve's work budget).  An answer that
        contradicts the model (:meth:`check`) is solved again without the start; if that fails too,
        the status is ``error`` (with the reason in ``detail``) and the point is kept only if it
        meets every row, bound and integrality.
        """
        meter = current()
        began = meter.spent
        res = self._run(time_limit, start)
        why = self.check(res.x, res.objective, res.dual_bound, res.status)
        if why and start is not None and self.is_mip:
            left = time_limit - (meter.spent - began)
            if left > 0:
                res = self._run(left, None)
                why = self.check(res.x, res.objective, res.dual_bound, res.status)
        if why:  # never "optimal"; a stopped run stays stopped, its point kept only if it is feasible
            x = res.x
            if x is not None and self.check(x, self.value(x), -INF, "feasible"):
                x = None
            objective = float("nan") if x is None else self.value(x)
            status = "time_limit" if res.status == "time_limit" else "error"
            res = replace(
                res,
                status=status,
                detail=f"HiGHS's answer fails its model: {why}",
                x=x,
                objective=objective,
                row_dual=None,
                col_dual=None,
            )
        return replace(res, seconds=meter.spent - began)

    def _run(self, time_limit: float, start: Array | None) -> Solve:
        h = self.h
        meter = current()
        size = model_size(self.n_rows, self.n_cols)
        iterations, ipm, nodes = run_limits(time_limit + self.limit_slack, meter.node_work, size)
        h.setOptionValue("simplex_iteration_limit", iterations)
        h.setOptionValue("qp_iteration_limit", iterations)
        h.setOptionValue("ipm_iteration_limit", ipm)
        if self.is_mip:
            h.setOptionValue("mip_max_nodes", nodes)
        # the wall clock only guards against a hang: HiGHS's run clock adds up over every run of this
        # object and its limit applies to that sum, so the limit given is that sum plus the guard's time left
        left = meter.guard_left()
        h.setOptionValue("time_limit", float(h.getRunTime()) + max(left, 0.0) if left < INF else INF)
        self._deadline[0] = meter.guard
        if self.is_mip or not self._warm:  # the answer depends on this model and start only, never on earlier runs
            h.clearSolver()
        if start is not None and self.is_mip:
            h.setSolution(self.n_cols, self._cols, np.asarray(start, dtype=float))
        run = h.run()
        self._deadline[0] = np.inf
        model_status = h.getModelStatus()
        info = h.getInfo()
        meter.check_guard()
        meter.spent += run_work(
            size,
            max(info.simplex_iteration_count, 0)
            + max(info.crossover_iteration_count, 0)
            + max(info.qp_iteration_count, 0),
            info.ipm_iteration_count,
            info.mip_node_count,
            meter.node_work,
            mip_root_work(self.n_rows, int(self._integer.sum())) if self.is_mip else 0.0,
        )
        status = _STATUS_NAMES.get(model_status, "error") if run != HighsStatus.kError else "error"
        has_point = info.primal_solution_status == 2
        sol = h.getSolution()
        x = np.array(sol.col_value, dtype=float) if has_point else None
        objective = float(info.objective_function_value) if has_point else float("nan")
        if self.is_mip:
            dual_bound = float(info.mip_dual_bound)
            row_dual = None
        else:
            dual_bound = objective
            row_dual = np.array(sol.row_dual, dtype=float) if has_point else None
        col_dual = None if self.is_mip or not has_point else np.array(sol.col_dual, dtype=float)
        return Solve(
            status=status,
            detail=h.modelStatusToString(model_status),
            x=x,
            objective=objective,
            dual_bound=dual_bound,
            row_dual=row_dual,
            col_dual=col_dual,
            seconds=0.0,
        )


def _interrupt(
    kind: cb.HighsCallbackType,
    message: str,
    data_out: cb.HighsCallbackOutput,
    data_in: cb.HighsCallbackInput,
    deadline: Any,
) -> None:
    """HiGHS's interrupt callback: stop once the wall clock passes the solve's guard (``deadline[0]``)."""
    if data_in is not None and wall() > deadline[0]:
        data_in.user_interrupt = True
