"""The triage's common case without binaries: the set of dimensions kept is forced.

Grid units and rows as in :class:`~setupfix.optimize.exact.triage.model.TriageRows`.  The triage keeps the
most dimensions in tolerance with every held dimension at or above its no-harm floor f_q ≤ 0, then
maximises the kept margins in the leximin order, then takes the least Σ c k².  Its binaries choose
*which* dimensions are kept; they are not needed when that choice is forced:

* a dimension q not held is **lost** when no point meeting the held dimensions' rows brings it into
  tolerance.  Proof: the LP ``max s  s.t.  G_j k + s ≤ g_j (rows of q), G_h k ≤ g_h − f_h (held rows),
  k in the box``, its weights checked in numpy by weak duality (:func:`lost_bound`) — every such
  point has margin_q below the bound;
* K = every dimension that can be kept (held, or a candidate) but the lost ones.  If the max–min of
  the margins of K alone (the rows of the others dropped) is t₁ ≥ 0 on the grid, a point keeps all of
  K and no harm is done (f_q ≤ 0 ≤ t₁), so K is the triage's kept set at every optimal point.

Then the triage's answer is the leximin of K's margins over the whole grid: its optimal points all have
every margin of K at least t₁ ≥ 0, so they lie in the triage's feasible set, which they maximise a
fortiori; their least norm is the triage's least norm.  That is
:func:`~setupfix.optimize.exact.leximin.levels.leximin` with the lost dimensions left out (floor −inf) and
:func:`~setupfix.optimize.exact.leximin.levels.leximin_least_norm` — no binaries, each level proved as in the
feasible case.  Level 1 is the grid optimum (:func:`~setupfix.optimize.exact.grid_optimum.grid_optimum`)
of K's rows.  When K cannot all be kept (t₁ < 0, or some lost dimension not proved lost), the caller
goes on with the MILPs of :mod:`~setupfix.optimize.exact.triage.solve`.

Which candidates are probed: those the LP over K names (positive weight on one of their rows),
repeated until K's LP bound is ≥ 0 or no probed candidate is lost.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_array, hstack

from setupfix.optimize.exact.grid import TOL
from setupfix.optimize.exact.grid_optimum import grid_optimum
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.least_norm.grid import LeastNorm
from setupfix.optimize.exact.leximin.level import LevelValue
from setupfix.optimize.exact.leximin.levels import Leximin, leximin, leximin_least_norm
from setupfix.optimize.exact.lp_bound import lp_bound
from setupfix.optimize.exact.session import GridRows, Session
from setupfix.optimize.exact.triage.model import TriageRows
from setupfix.optimize.exact.work import now

__all__ = ["Forced", "forced_triage", "lost_bound"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: A dimension is kept at margin ≥ −KEPT_TOL steps (:meth:`TriageRows.kept`), held rows hold to it too.
KEPT_TOL = 1e-6


@dataclass(frozen=True)
class Forced:
    """Outcome of :func:`forced_triage`.

    Attributes
    ----------
    keep : ndarray of bool, shape (n_dims,)
        The kept set K (the lost dimensions and those the box excludes are False).
    lex : Leximin
        The leximin of K's margins (``lex.stopped``: the limit stopped its levels).
    least : LeastNorm
        The least Σ c k² among its optimal points (``least.k``: the answer).
    bound : float
        LP bound [steps] on the smallest margin of K (the held rows hold at it: it is ≥ 0 ≥ their floors).
    path : tuple of str
    calls : int
        Solver calls.
    """

    keep: Mask
    lex: Leximin
    least: LeastNorm
    bound: float
    path: tuple[str, ...]
    calls: int


def lost_bound(t: TriageRows, q: int, time_limit: float) -> float:
    """Upper bound [steps] on dimension q's margin at every point meeting the held rows (+inf: none).

    From the LP ``max s  s.t.  G_j k + s ≤ g_j (q's rows), G_h k ≤ g_h − f_h (held rows)``: with its row
    weights y ≥ 0 (q's rows, scaled to sum 1) and w ≥ 0 (held rows), for every k in the box
    ``Σ y_j (g_j − G_j k) + Σ w_h (g_h − f_h − G_h k) ≤ C`` where C is computed here from y, w and the
    box (weak duality; the solver's objective is not trusted).  Where the held rows hold to −KEPT_TOL
    the second sum is ≥ −KEPT_TOL·Σw, so margin_q ≤ Σ y_j m_j ≤ C + KEPT_TOL·Σw.
    """
    rows = np.flatnonzero(t.row_dim == q)
    hard = t.hard_rows
    if rows.size == 0:
        return np.inf
    a = hstack([csr_array(t.G[np.r_[rows, hard]]), csr_array(np.r_[np.ones(rows.size), np.zeros(hard.size)][:, None])])
    rhs = np.r_[t.g[rows], t.g[hard] - t.hard_min]
    model = LinearModel(
        np.r_[np.zeros(t.n), -1.0], a, np.full(rhs.size, -INF), rhs, np.r_[t.kmin, -INF], np.r_[t.kmax, t.top + 1.0]
    )
    res = model.solve(max(time_limit, 1e-3))
    if res.status != "optimal" or res.row_dual is None:
        return np.inf
    weights = np.maximum(-res.row_dual, 0.0)
    y, w = weights[: rows.size], weights[rows.size :]
    total = float(y.sum())
    if not np.isfinite(total) or total <= 0:
        return np.inf
    y, w = y / total, w / total
    c = y @ t.G[rows] + w @ t.G[hard]
    bound = float(y @ t.g[rows] + w @ rhs[rows.size :] + np.sum(np.maximum(-c * t.kmin, -c * t.kmax)))
    return bound + KEPT_TOL * float(w.sum())


def _restricted(session: Session, keep_rows: Mask) -> Session:
    rows = session.rows
    sub = GridRows(rows.g_rows[keep_rows], rows.g[keep_rows], rows.kmin, rows.kmax, rows.cost)
    return Session(sub, session.settings, session.time_limit, session.clock)


def forced_triage(session: Session, t: TriageRows, k_start: Array, probe_end: float) -> Forced | None:
    """The triage when its kept set is forced (see the module text); None when it is not proved forced.

    Parameters
    ----------
    session : Session
        The solve (all rows; its clock bounds every stage).
    t : TriageRows
        The same rows, their dimensions and the held dimensions' floors.
    k_start : ndarray of shape (n,)
        A grid point to start the leximin from.
    probe_end : float
        ``now()`` after which no candidate is probed and no LP over K is started.
    """
    settings, clock = session.settings, session.clock
    keep = np.zeros(t.n_dims, bool)
    keep[t.keepable] = True
    probed = np.zeros(t.n_dims, bool)
    path: list[str] = []
    calls = 0
    while True:
        if now() >= probe_end:
            return None
        keep_rows = keep[t.row_dim]
        if not keep_rows.any():
            return None  # nothing to centre: the MILP path states it
        sub = _restricted(session, keep_rows)
        lp = lp_bound(sub)
        calls += 1
        if lp is None:
            return None
        if lp.t >= -TOL:
            break
        suspects = np.unique(t.row_dim[keep_rows][lp.y > 1e-9])
        suspects = suspects[~t.held[suspects] & ~probed[suspects]]
        lost = []
        for q in suspects:
            if now() >= probe_end:
                return None
            probed[q] = True
            calls += 1
            if lost_bound(t, int(q), probe_end - now()) < -KEPT_TOL:
                lost.append(int(q))
        if not lost:
            return None  # K's LP bound is below 0 and no dimension it names is proved lost: not forced
        keep[lost] = False
        path.append(
            f"triage: {len(lost)} dimension(s) proved out of tolerance at every point that keeps the "
            "held ones (LP, weak duality)"
        )
    keep_rows = keep[t.row_dim]
    opt = grid_optimum(sub, lp)
    calls += opt.calls
    if opt.t < -TOL:
        return None  # K's grid optimum is below 0 (or not found): the binaries decide
    y = np.zeros(t.g.size)
    y[keep_rows] = lp.y
    first = None if opt.stopped is not None else LevelValue(opt.t, opt.k, lp.t, y)
    path += [
        *opt.path,
        f"triage: the {int(keep.sum())} dimensions that can be kept all reach {opt.t:+.4g} steps "
        "(kept set forced: leximin of their margins, no binaries)",
    ]
    floors = np.where(keep, np.nan, -np.inf)
    stage_end = clock.deadline - settings.leximin_norm_share * session.time_limit
    lex = leximin(session, t.row_dim, t.n_dims, opt.k, opt.t, first=first, floors=floors, stage_end=stage_end)
    share = settings.box_share if lex.stopped is None else settings.stopped_box_share
    least = leximin_least_norm(session, lex, t.row_dim, share)
    k = least.k
    if not (t.hard_ok(k) and np.array_equal(t.kept(k), keep | t.held)):
        return None  # the answer does not keep exactly K (not expected): the MILPs decide
    return Forced(keep, lex, least, lp.t, tuple(path + list(lex.path) + list(least.path)), calls + lex.calls + 1)
