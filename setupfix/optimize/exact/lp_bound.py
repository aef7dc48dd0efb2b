"""Stage 1 of the exact solve: the margin rows in grid units and the LP bound on the error budget.

The max–min objective f1 (eq. 8) is linear in the corrections: "maximise t subject to
every margin ≥ t and the register bounds" is a linear programme whose optimum t_LP
bounds every correction, on the grid or not.  Its dual prices name the binding
dimensions and feed the grid-optimum stage's bounds
(:func:`~setupfix.optimize.exact.grid.dual_bound`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import SolverError
from setupfix.optimize.exact.highs import INF
from setupfix.optimize.exact.session import Session
from setupfix.optimize.problem import CorrectionProblem

__all__ = ["LPBound", "lp_bound", "margin_rows", "rows_to_dimensions"]

Array = npt.NDArray[np.float64]


def margin_rows(problem: CorrectionProblem, quantum: float = 1e-3) -> tuple[Array, Array]:
    """Margin constraints in grid units: ``G·k + t ≤ g`` means every margin ≥ t.

    For dimension q with composite column a_q, measured deviation d_q and limits
    L_q < U_q the two margins are U_q − (d_q + h·a_qᵀk) and (d_q + h·a_qᵀk) − L_q
    (eqs. 5–6 per dimension); in steps of h they give the rows
    ``a_qᵀk + t ≤ U_q/h − d_q/h`` and ``−a_qᵀk + t ≤ d_q/h − L_q/h``, with d_q/h
    rounded to ``quantum`` steps (:attr:`~setupfix.optimize.exact.settings.ExactSettings.quantum`).

    Returns
    -------
    G : ndarray of shape (n_rows, n_free)
        Rows over the free registers only (upper-limit rows first, then lower-limit rows).
    g : ndarray of shape (n_rows,)
    """
    h = problem.resolution
    a = problem.composite[problem.free].T  # (m, n_free)
    upper_ok = np.isfinite(problem.upper)
    lower_ok = np.isfinite(problem.lower)
    dev = np.round(problem.deviation / h / quantum) * quantum
    g_rows = np.vstack([a[upper_ok], -a[lower_ok]])
    g = np.concatenate([(problem.upper / h)[upper_ok] - dev[upper_ok], dev[lower_ok] - (problem.lower / h)[lower_ok]])
    return g_rows, g


def rows_to_dimensions(problem: CorrectionProblem, rows: npt.NDArray[np.bool_]) -> tuple[str, ...]:
    """Dimension IDs of flagged margin rows (upper-limit rows first, as in :func:`margin_rows`)."""
    ids = np.array(problem.dimension_ids, dtype=object)
    upper_ids = ids[np.isfinite(problem.upper)]
    lower_ids = ids[np.isfinite(problem.lower)]
    flagged = set(upper_ids[rows[: upper_ids.size]]) | set(lower_ids[rows[upper_ids.size :]])
    return tuple(d for d in problem.dimension_ids if d in flagged)


@dataclass(frozen=True)
class LPBound:
    """The LP optimum of eq. 8 in grid units.

    Attributes
    ----------
    t : float
        t_LP [steps]: no correction, on the grid or not, has every margin above it.
    k : ndarray of shape (n,)
        The LP point [steps].
    y : ndarray of shape (r,)
        Row weights ≥ 0 of its dual (positive on the binding rows).
    """

    t: float
    k: Array
    y: Array


def lp_bound(session: Session) -> LPBound | None:
    """Solve the LP of eq. 8; None when its time limit was reached first.

    A HiGHS failure is retried once on a model built from scratch; a second one raises
    :class:`~setupfix.core.errors.SolverError`.  An LP with more than ``ipm_min_rows`` rows is
    solved by the interior-point method (with crossover: its duals are a basis').
    """
    g = session.rows.g
    lp = session.lp_model()
    lp.set_row_bounds(np.full(g.size, -INF), g)
    if g.size > session.settings.ipm_min_rows:
        lp.h.setOptionValue("solver", "ipm")
    res = lp.solve(session.clock.left())
    lp.h.setOptionValue("solver", "choose")
    if res.status not in ("optimal", "time_limit") and session.clock.left() > 0:  # one retry from scratch
        session.drop_lp()
        lp = session.lp_model()
        lp.set_row_bounds(np.full(g.size, -INF), g)
        res = lp.solve(session.clock.left())
    if res.status == "time_limit":
        return None
    if res.status != "optimal" or res.x is None or res.row_dual is None:
        raise SolverError(f"LP stage failed: HiGHS answered {res.detail!r}")
    return LPBound(float(res.x[-1]), res.x[:-1], np.maximum(-res.row_dual, 0.0))
