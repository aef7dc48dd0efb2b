"""Triage: when no correction brings every dimension into tolerance (issue 13).

A hopeless dimension must not ruin good ones.  In grid units (rows ``G k ≤ g`` of
:func:`setupfix.optimize._exact.margin_rows`, each row belonging to one dimension),
with a binary z_q per dimension ("kept in tolerance") and big-M constants from the
register bounds, three exact MILPs in turn (lexicographic optimum):

1. **Most dimensions in tolerance**: max Σ z_q s.t. G_j k ≤ g_j + M_j (1 − z_q(j)),
   M_j = max_box G_j k − g_j (a row with M_j ≤ 0 holds for every k).  Optimum N*.
2. **Largest error budget of those**: max t s.t. Σ z_q ≥ N*,
   G_j k + t ≤ g_j + (M_j + T)(1 − z_q(j)), 0 ≤ t ≤ T (T: the largest margin any row
   can have in the box).  Optimum t*.
3. **Least norm**: min Σ c_i k_i² s.t. Σ z_q ≥ N*, G_j k ≤ g_j − t* + (M_j + t*)(1 − z_q(j)),
   with k_i² as the upper envelope of its chords (exact on integers), chords added
   lazily where a solution violates s_i ≥ k_i² (:func:`~setupfix.optimize._chords.lazy_chords`).

No point can keep more than N* dimensions in tolerance, so every point that meets
Σ z ≥ N* keeps exactly the dimensions with z = 1; the dimensions given up are read
from the final point's own margins.  Each MILP is solved to a zero gap by HiGHS.
"""

from __future__ import annotations

import time

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array, hstack, vstack

from setupfix.errors import Note
from setupfix.optimize._base import make_result
from setupfix.optimize._chords import chord_rows, lazy_chords
from setupfix.optimize._grid import TOL
from setupfix.optimize._highs import INF, LinearModel
from setupfix.optimize._problem import CorrectionProblem, OptimizeResult
from setupfix.optimize._session import Session

__all__ = ["triage", "triaged_result"]

Array = npt.NDArray[np.float64]


def _status_word(status: str) -> str:
    return "time limit" if status == "time_limit" else f"HiGHS: {status}"


def triage(g_rows: Array, g: Array, row_dim: npt.NDArray[np.intp], n_dims: int, kmin: Array, kmax: Array,
           cost: Array, deadline: float, start: Array) -> tuple[Array, bool, str, tuple[str, ...]]:
    """Keep the most dimensions in tolerance, then their largest budget, then the least norm.

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); g : ndarray of shape (r,)
        Margin rows in grid steps (margin_j(k) = g_j − G_j k).
    row_dim : ndarray of int, shape (r,)
        Dimension index (0 … n_dims−1) of each row.
    kmin, kmax, cost : ndarray of shape (n,)
    deadline : float
        ``time.perf_counter()`` value at which to stop.
    start : ndarray of shape (n,)
        A grid point to start from (any point in the box).

    Returns
    -------
    k : ndarray of shape (n,)
        The triaged correction in steps (``start`` if nothing better was found).
    proved : bool
        All three stages solved to optimality.
    why : str
        Which stage stopped and why (empty when proved).
    stages : tuple of str
        The stages completed, for the record.
    """
    r, n = g_rows.shape
    hi = np.sum(np.maximum(g_rows * kmin, g_rows * kmax), axis=1)
    lo = np.sum(np.minimum(g_rows * kmin, g_rows * kmax), axis=1)
    big = np.maximum(hi - g, 0.0)  # M_j
    top = float(np.max(g - lo))  # no margin exceeds this
    zmat = csr_array(coo_array((np.ones(r), (np.arange(r), row_dim)), shape=(r, n_dims)))
    done: list[str] = []

    def left() -> float:
        return deadline - time.perf_counter()

    def in_tolerance(k: Array) -> npt.NDArray[np.bool_]:
        ok = np.ones(n_dims, bool)
        np.logical_and.at(ok, row_dim, g - g_rows @ k >= -TOL)
        return ok

    # 1. most dimensions in tolerance: columns k (n), z (n_dims)
    a1 = hstack([csr_array(g_rows), zmat.multiply(big[:, None])]).tocsr()
    m1 = LinearModel(np.r_[np.zeros(n), -np.ones(n_dims)], a1, np.full(r, -INF), g + big,
                     np.r_[kmin, np.zeros(n_dims)], np.r_[kmax, np.ones(n_dims)],
                     integer=np.ones(n + n_dims, bool))
    z0 = in_tolerance(start).astype(float)
    res = m1.solve(left(), np.r_[start, z0])
    best = start
    if res.x is not None:
        k = np.clip(np.rint(res.x[:n]), kmin, kmax)
        if in_tolerance(k).sum() >= in_tolerance(best).sum():
            best = k
    if res.status != "optimal":
        return best, False, f"most dimensions in tolerance: {_status_word(res.status)}", tuple(done)
    kept = int(in_tolerance(best).sum())
    done.append(f"{kept} of {n_dims} dimensions can be kept in tolerance")
    if kept == 0:  # no budget to keep: the least correction of all is the box point nearest zero
        done.append("least norm")
        return np.clip(np.zeros(n), kmin, kmax), True, "", tuple(done)

    # 2. largest error budget of the kept dimensions: columns k, z, t
    bigt = big + top
    a2 = vstack([hstack([csr_array(g_rows), zmat.multiply(bigt[:, None]), csr_array(np.ones((r, 1)))]),
                 csr_array(np.r_[np.zeros(n), np.ones(n_dims), 0.0][None, :])]).tocsr()
    m2 = LinearModel(np.r_[np.zeros(n + n_dims), -1.0], a2, np.r_[np.full(r, -INF), kept], np.r_[g + bigt, INF],
                     np.r_[kmin, np.zeros(n_dims), 0.0], np.r_[kmax, np.ones(n_dims), top],
                     integer=np.r_[np.ones(n + n_dims, bool), False])
    ok = in_tolerance(best)
    t0 = float(np.min((g - g_rows @ best)[ok[row_dim]])) if ok.any() else 0.0
    res = m2.solve(left(), np.r_[best, ok.astype(float), max(t0, 0.0)])
    if res.x is not None:
        k = np.clip(np.rint(res.x[:n]), kmin, kmax)
        ok_k = in_tolerance(k)
        if ok_k.sum() >= kept and (g - g_rows @ k)[ok_k[row_dim]].min() > t0:
            best, t0 = k, float((g - g_rows @ k)[ok_k[row_dim]].min())
    if res.status != "optimal":
        return best, False, f"error budget of the kept dimensions: {_status_word(res.status)}", tuple(done)
    t_star = t0
    done.append("their error budget")

    # 3. least Σ c k² with at least `kept` dimensions at margin ≥ t*: columns k, s, z
    bigs = big + t_star

    chords = [{0, int(abs(v)), max(int(abs(v)) - 1, 0)} for v in best]
    a_ch, rhs_ch = chord_rows([(i, j) for i, js in enumerate(chords) for j in sorted(js)], n, 2 * n + n_dims)
    a3 = vstack([hstack([csr_array(g_rows), csr_array((r, n)), zmat.multiply(bigs[:, None])]),
                 csr_array(np.r_[np.zeros(2 * n), np.ones(n_dims)][None, :]), a_ch]).tocsr()
    m3 = LinearModel(np.r_[np.zeros(n), cost, np.zeros(n_dims)], a3,
                     np.r_[np.full(r, -INF), kept, np.full(rhs_ch.size, -INF)], np.r_[g - t_star + bigs, INF, rhs_ch],
                     np.r_[kmin, np.zeros(n), np.zeros(n_dims)], np.r_[kmax, np.full(n, INF), np.ones(n_dims)],
                     integer=np.r_[np.ones(n, bool), np.zeros(n, bool), np.ones(n_dims, bool)])

    def feasible(k: Array) -> bool:
        ok_k = in_tolerance(k)
        return bool(ok_k.sum() >= kept and (g - g_rows @ k)[ok_k[row_dim]].min() >= t_star - TOL)

    out = lazy_chords(m3, n, chords, cost, kmin, kmax, best, feasible,
                      lambda k: np.r_[k, k**2, in_tolerance(k).astype(float)], deadline, integer=True)
    if out.proved:
        done.append("least norm")
    best = best if out.best is None else out.best
    return best, out.proved, "" if out.proved else f"least norm: {out.why}", tuple(done)


def triaged_result(problem: CorrectionProblem, session: Session, k_start: Array, path: list[str],
                   notes: list[Note], calls: int, bound: float, name: str) -> OptimizeResult:
    """The triage stage: no correction brings every dimension into tolerance, so :func:`triage` decides.

    The dimensions given up are read from the final point's own margins (below −quantum);
    the result says which, and that they need the NC program or the process, not the setup.
    """
    rows, clock = session.rows, session.clock
    upper_ok, lower_ok = np.isfinite(problem.upper), np.isfinite(problem.lower)
    row_dim = np.r_[np.flatnonzero(upper_ok), np.flatnonzero(lower_ok)]
    m = len(problem.dimension_ids)
    k, proved, why, done = triage(rows.g_rows, rows.g, row_dim, m, rows.kmin, rows.kmax, rows.cost,
                                  clock.deadline, k_start)
    clock.lap("triage")
    path.append("triage: " + ", ".join(done) if done else "triage")
    x = np.zeros(problem.n_registers)
    x[problem.free] = k * problem.resolution
    margins = problem.margins(x)
    quantum = session.settings.quantum * problem.resolution
    given_up = tuple(d for d, v in zip(problem.dimension_ids, margins, strict=True) if v < -quantum)
    kept = margins >= -quantum
    low = margins[kept].min() if kept.any() else 0.0
    binding = tuple(d for d, v, ok in zip(problem.dimension_ids, margins, kept, strict=True)
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
    result = make_result(problem, x, optimizer=name, evaluations=calls + 3,
                         seconds=time.perf_counter() - clock.start, status=status, bound=bound,
                         message=message, binding=binding, guard=False)
    result.extra.update(extra)
    result.given_up = given_up
    result.notes = tuple(notes)
    return result
