"""Thin layer over HiGHS's own Python interface (highspy) for the exact optimiser.

Why highspy and not scipy's ``linprog``/``milp``: scipy rebuilds the whole model and
re-validates every option on each call; highspy keeps the solver model, so one solve can
change only row bounds or add rows (lazy cuts) between runs.  Each run starts from a
cleared solver (no basis or incumbent of an earlier run): where the least norm is attained
at two grid points, the answer must depend on this model and start only.  HiGHS's run
clock, though, is not cleared: it adds up over every run of one object, and its
``time_limit`` applies to that sum, so :meth:`LinearModel.solve` sets the limit to the
clock's reading plus the run's own allowance (and the exact optimiser keeps no model beyond
one solve: :class:`~setupfix.optimize._session.Session`).

Every solver object is created silent (``output_flag`` off: nothing may reach stdout,
which carries ``--json``) and single-threaded (``threads`` = 1: the solves here are
small; HiGHS's MIP thread pool costs more than it gains, and a batch runs its own
workers).  The private ``_Highs`` class is used because the public ``Highs`` subclass
prints a banner on stdout when it is constructed and installs callbacks we do not use.
"""

from __future__ import annotations

from dataclasses import dataclass

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
    kHighsInf,
)
from scipy.sparse import csc_array

__all__ = ["INF", "Colwise", "LinearModel", "Solve"]

Array = npt.NDArray[np.float64]
INF = float(kHighsInf)

#: Model statuses that are answers (optimal, proven infeasible, time limit with or without a point).
_STATUS_NAMES = {
    HighsModelStatus.kOptimal: "optimal",
    HighsModelStatus.kInfeasible: "infeasible",
    HighsModelStatus.kUnboundedOrInfeasible: "infeasible",
    HighsModelStatus.kUnbounded: "unbounded",
    HighsModelStatus.kTimeLimit: "time_limit",
    HighsModelStatus.kIterationLimit: "time_limit",
    HighsModelStatus.kInterrupt: "time_limit",
}


@dataclass
class Solve:
    """Outcome of one HiGHS run.

    Attributes
    ----------
    status : str
        ``optimal``, ``infeasible``, ``unbounded``, ``time_limit`` or ``error`` (anything
        else HiGHS answers, e.g. "Solve error"); ``detail`` gives HiGHS's own words.
    x : ndarray of shape (n_cols,) or None
        Primal point, when HiGHS has a feasible one.
    objective : float
        Objective of ``x`` (nan without a point).
    dual_bound : float
        Best bound proved (MIP: ``mip_dual_bound``; LP: the objective).
    row_dual, col_dual : ndarray of shape (n_rows,) / (n_cols,) or None
        Duals of an LP or QP (HiGHS's signs: for a minimisation, ≤ 0 on a row or column at
        its upper bound, ≥ 0 at its lower bound).
    seconds : float
        HiGHS's own run time of this run.
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
        Where each column's entries start in ``index``/``value``.
    index : ndarray of int32, shape (nnz,)
        Row of each entry.
    value : ndarray of shape (nnz,)
    """

    n_rows: int
    n_cols: int
    start: npt.NDArray[np.int32]
    index: npt.NDArray[np.int32]
    value: Array

    @classmethod
    def of(cls, a: object) -> Colwise:
        """From a dense array of shape (n_rows, n_cols) or any scipy sparse array."""
        if isinstance(a, np.ndarray):  # dense (small models): column-wise arrays by numpy, no scipy round trip
            at = np.asarray(a, dtype=float).T
            nonzero = at != 0
            start = np.r_[0, np.cumsum(np.sum(nonzero, axis=1))]
            return cls(int(at.shape[1]), int(at.shape[0]), start.astype(np.int32),
                       np.nonzero(nonzero)[1].astype(np.int32), at[nonzero])
        mat = csc_array(a)
        return cls(int(mat.shape[0]), int(mat.shape[1]), mat.indptr.astype(np.int32), mat.indices.astype(np.int32),
                   np.asarray(mat.data, dtype=float))


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
    """

    def __init__(self, c: Array, a: object, row_lo: Array, row_hi: Array, col_lo: Array, col_hi: Array,
                 integer: npt.NDArray[np.bool_] | None = None) -> None:
        mat = a if isinstance(a, Colwise) else Colwise.of(a)
        self.n_cols, self.n_rows = mat.n_cols, mat.n_rows
        self.is_mip = integer is not None and bool(np.any(integer))
        kinds = np.zeros(self.n_cols, dtype=np.int32) if integer is None else np.asarray(integer, dtype=np.int32)
        self.h = new_solver()
        if self.is_mip:
            self.h.setOptionValue("mip_rel_gap", 0.0)
        # the arrays go to HiGHS as they are (column-wise, minimise, no offset; integrality 0/1 per column)
        self._check(self.h.passModel(  # the array overload
            self.n_cols, self.n_rows, int(mat.value.size), int(MatrixFormat.kColwise), int(ObjSense.kMinimize), 0.0,
            np.asarray(c, dtype=float), np.asarray(col_lo, dtype=float), np.asarray(col_hi, dtype=float),
            np.asarray(row_lo, dtype=float), np.asarray(row_hi, dtype=float), mat.start, mat.index, mat.value,
            kinds), "passModel")
        self._rows = np.arange(self.n_rows, dtype=np.int32)
        self._cols = np.arange(self.n_cols, dtype=np.int32)

    @staticmethod
    def _check(status: HighsStatus, what: str) -> None:
        if status == HighsStatus.kError:
            raise RuntimeError(f"HiGHS refused {what}")

    def set_hessian_diagonal(self, diag: Array) -> None:
        """Make the objective cᵀx + ½ Σ diag_i x_i² (a convex QP; continuous columns only)."""
        diag = np.asarray(diag, dtype=float)
        idx = np.arange(diag.size, dtype=np.int32)
        self._check(self.h.passHessian(diag.size, diag.size, int(HessianFormat.kTriangular), idx,
                                       idx.copy(), diag), "passHessian")

    def make_integer(self, cols: npt.NDArray[np.intp]) -> None:
        """Turn columns into integer ones (the LP becomes a MILP, solved to a zero gap)."""
        cols = np.asarray(cols, dtype=np.int32)
        types = np.array([HighsVarType.kInteger] * cols.size)
        self._check(self.h.changeColsIntegrality(cols.size, cols, types), "changeColsIntegrality")
        if not self.is_mip:
            self.is_mip = True
            self.h.setOptionValue("mip_rel_gap", 0.0)

    def prefer_proof(self) -> None:
        """A near-optimal start is known: no improvement heuristics (RINS, RENS) and pseudo-cost
        branching without strong-branching reliability, which roughly halves the time HiGHS needs
        to prove the least-norm MILPs at shop scale (``bench/exact_scaling.py``)."""
        for name, value in (("mip_heuristic_run_rins", False), ("mip_heuristic_run_rens", False),
                            ("mip_pscost_minreliable", 0)):
            self.h.setOptionValue(name, value)

    def set_row_bounds(self, lo: Array, hi: Array) -> None:
        """Change every row's bounds (the deviations of a new report enter here)."""
        self._check(self.h.changeRowsBounds(  # type: ignore[attr-defined]  # in highspy, not its stubs
            self.n_rows, self._rows, np.asarray(lo, dtype=float),
                                            np.asarray(hi, dtype=float)), "changeRowsBounds")

    def set_col_bounds(self, cols: npt.NDArray[np.int32], lo: Array, hi: Array) -> None:
        cols = np.asarray(cols, dtype=np.int32)
        self._check(self.h.changeColsBounds(cols.size, cols, np.asarray(lo, dtype=float),
                                            np.asarray(hi, dtype=float)), "changeColsBounds")

    def add_rows(self, a: object, lo: Array, hi: Array) -> None:
        """Append rows (lazy cuts); ``a`` has shape (k, n_cols)."""
        mat = csc_array(a).tocsr()
        k = int(mat.shape[0])
        self._check(self.h.addRows(k, np.asarray(lo, dtype=float), np.asarray(hi, dtype=float), mat.nnz,
                                   mat.indptr[:-1].astype(np.int32), mat.indices.astype(np.int32),
                                   mat.data.astype(float)), "addRows")
        self.n_rows += k
        self._rows = np.arange(self.n_rows, dtype=np.int32)

    def solve(self, time_limit: float, start: Array | None = None) -> Solve:
        """Run HiGHS for at most ``time_limit`` seconds (optionally from a feasible ``start``)."""
        h = self.h
        # HiGHS's run clock adds up over every run of this object and its limit applies to that sum:
        # the limit given is this run's own
        h.setOptionValue("time_limit", float(h.getRunTime()) + float(max(time_limit, 1e-3)))
        h.clearSolver()  # the answer depends on this model and start only, never on earlier runs
        clock = float(h.getRunTime())
        if start is not None and self.is_mip:
            h.setSolution(self.n_cols, self._cols, np.asarray(start, dtype=float))
        run = h.run()
        model_status = h.getModelStatus()
        info = h.getInfo()
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
        return Solve(status=status, detail=h.modelStatusToString(model_status), x=x, objective=objective,
                     dual_bound=dual_bound, row_dual=row_dual, col_dual=col_dual,
                     seconds=float(h.getRunTime()) - clock)
