"""Leximin by counts: the generic, always-correct way past a discrete conflict (MILPs with binaries).

Grid units as in :mod:`setupfix.optimize._session`; dimensions fixed with floors v_q stay so,
every *active* dimension has margin ≥ t₀ (the level where the progressive filling of
:mod:`setupfix.optimize._leximin` stopped).  The sorted margins of the active dimensions form a
step function with values t₀ = t₁ < t₂ < … and N_i = how many are ≥ t_i; a grid point is at
least as good (leximin) iff #{q : M_q ≥ t_i} ≥ N_i for every i.  So, in turn:

* **count** at t_i: max Σ w_q, w_q = 1 ⇒ M_q ≥ t_i + ε (binaries w, big-M rows from the box),
  subject to the blocks found so far — N_{i+1} = the optimum; none above: done;
* **value**: max t s.t. Σ w_q ≥ N_{i+1}, w_q = 1 ⇒ M_q ≥ t — t_{i+1} = the optimum;
  the block (t_{i+1}, N_{i+1}) joins the constraints.

The least norm among the leximin-optimal points is the chord MILP of Σ c k² (chords of k² added
lazily, :func:`~setupfix.optimize._chords.lazy_chords`) with the same blocks.  Each MILP is
solved to a zero gap; the limit stops the chain with the best point found.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array, hstack, vstack

from setupfix.optimize._chords import chord_rows, lazy_chords
from setupfix.optimize._grid import TOL, rounded_rhs
from setupfix.optimize._grid_least_norm import LeastNorm
from setupfix.optimize._highs import INF, LinearModel
from setupfix.optimize._session import Session

__all__ = ["CountLevels", "count_least_norm", "count_levels"]

#: Link the nested blocks' binaries (w_i,q ≤ w_(i−1),q); ``bench/leximin_counts.py`` compares without.
LINK = True

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CountLevels:
    """The count constraints of the active dimensions and the levels they make.

    Attributes
    ----------
    k : ndarray of shape (n,)
        A grid point meeting them all.
    floors : ndarray of shape (n_dims,)
        The fixed dimensions' floors (NaN: active, decided by the counts).
    t0 : float
        Every active dimension has margin ≥ t0 [steps].
    blocks : tuple of (float, int)
        (t_i, N_i): at least N_i active dimensions have margin ≥ t_i.
    levels : tuple of (float, int)
        The active dimensions' part of the leximin vector: (value, how many at it).
    proved, why, path, calls
        Every MILP optimal (else why not), the steps taken, solver calls.
    """

    k: Array
    floors: Array
    t0: float
    blocks: tuple[tuple[float, int], ...]
    levels: tuple[tuple[float, int], ...]
    proved: bool
    why: str
    path: tuple[str, ...]
    calls: int


class _Rows:
    """The active/fixed rows and the big-M blocks of one solve."""

    def __init__(self, session: Session, row_dim: npt.NDArray[np.intp], floors: Array, t0: float) -> None:
        rows = session.rows
        self.g_rows, self.g, self.kmin, self.kmax = rows.g_rows, rows.g, rows.kmin, rows.kmax
        self.n = rows.n_free
        f = floors[row_dim]
        self.active_dims = np.flatnonzero(np.isnan(floors))
        self.n_active = self.active_dims.size
        pos = np.full(floors.size, -1)
        pos[self.active_dims] = np.arange(self.n_active)
        self.act = np.isnan(f)
        self.fix = np.isfinite(f)
        self.col = pos[row_dim[self.act]]  # binary column (within a block) of each active row
        level = np.where(self.act, t0, np.where(self.fix, f, -np.inf))
        self.base_hi = np.where(self.act | self.fix, rounded_rhs(self.g, rows.d, rows.zero, level), np.inf)
        # the least margin an active row can have over the base rows (its lattice value at or above t0)
        self.r = np.where(rows.zero, self.g, self.g - self.base_hi)[self.act]
        self.keep = self.act | self.fix
        self.f = f
        self.t0 = t0
        self.row_dim = row_dim
        self.hi_box = np.sum(np.maximum(self.g_rows * self.kmin, self.g_rows * self.kmax), axis=1)
        self.lo_box = np.sum(np.minimum(self.g_rows * self.kmin, self.g_rows * self.kmax), axis=1)

    def margins(self, k: Array) -> Array:
        """Margins of the active dimensions at k, shape (n_active,)."""
        out = np.full(self.n_active, np.inf)
        np.minimum.at(out, self.col, (self.g - self.g_rows @ k)[self.act])
        return out

    def base_ok(self, k: Array) -> bool:
        m = self.g - self.g_rows @ k
        return bool(np.all(m[self.fix] >= self.f[self.fix] - TOL) and np.all(m[self.act] >= self.t0 - TOL))

    def feasible(self, k: Array, blocks: list[tuple[float, int]]) -> bool:
        m = self.margins(k)
        return self.base_ok(k) and all(int(np.sum(m >= t - TOL)) >= c for t, c in blocks)

    def block(self, t: float | None, top: float) -> tuple[csr_array, Array, Array]:
        """Rows G_j k (+ t) + M w_q(j) ≤ g_j − t + M over the active rows: (matrix on w, M, rhs).

        M = level − t0: with w = 0 the row is the base row G_j k ≤ g_j − t0 (t ≤ ``top`` for the
        value question), so the big-M is a few steps, not the box's span.
        """
        # every active row already has G_j k ≤ g_j − t0 (the base rows): M_j = level − t0 relaxes it to that
        ga = self.g[self.act]
        level = top if t is None else t
        big = np.full(ga.size, max(level - self.t0, 0.0))
        rhs = ga + big - (0.0 if t is None else t)
        if t is not None:
            rhs = np.where(self.r < t - TOL, rhs, INF)  # a row whose lattice cannot be below t needs no big-M row
        w = csr_array(coo_array((big, (np.arange(self.act.sum()), self.col)), shape=(int(self.act.sum()),
                                                                                     self.n_active)))
        return w, big, rhs


def _model(rows: _Rows, blocks: list[tuple[float, int]], extra: int, question: tuple[float | None, int],
           objective: str, top: float, t_lo: float) -> tuple[LinearModel, int]:
    """The MILP: columns k (n), [t], blocks' binaries, the question's binaries (+ s for the norm)."""
    n, na = rows.n, rows.n_active
    r_act = int(rows.act.sum())
    with_t = question[0] is None
    nb = len(blocks) + 1
    width = n + extra + (1 if with_t else 0) + nb * na
    off = n + extra + (1 if with_t else 0)
    parts, lo, hi = [], [], []
    g_keep = csr_array(rows.g_rows[rows.keep])
    parts.append(hstack([g_keep, csr_array((g_keep.shape[0], width - n))]))
    lo.append(np.full(g_keep.shape[0], -INF))
    hi.append(rows.base_hi[rows.keep])
    g_act = csr_array(rows.g_rows[rows.act])
    for i, (t_i, c_i) in enumerate([*blocks, question]):
        wmat, _, rhs = rows.block(t_i, top)
        tcol = csr_array(np.ones((r_act, 1))) if t_i is None else None
        cols = [g_act, csr_array((r_act, extra))]
        if with_t:
            cols.append(tcol if tcol is not None else csr_array((r_act, 1)))
        cols += [csr_array((r_act, i * na)), wmat, csr_array((r_act, (nb - 1 - i) * na))]
        parts.append(hstack(cols))
        lo.append(np.full(r_act, -INF))
        hi.append(rhs)
        if i < len(blocks) or objective != "count":
            count = np.zeros(width)
            count[off + i * na: off + (i + 1) * na] = 1.0
            parts.append(csr_array(count[None, :]))
            lo.append(np.array([float(c_i)]))
            hi.append(np.array([INF]))
    if nb > 1 and LINK:  # nested blocks (t rises block by block): w_i,q = 1 ⇒ M_q ≥ t_i ≥ t_(i−1), so
        # w_i,q ≤ w_(i−1),q is valid (raise w_(i−1),q) and cuts the LP relaxation and symmetric branches
        pairs = np.arange((nb - 1) * na)
        link = coo_array((np.r_[np.ones(pairs.size), -np.ones(pairs.size)],
                          (np.r_[pairs, pairs], np.r_[off + na + pairs, off + pairs])), shape=(pairs.size, width))
        parts.append(csr_array(link))
        lo.append(np.full(pairs.size, -INF))
        hi.append(np.zeros(pairs.size))
    c = np.zeros(width)
    if objective == "count":
        c[off + len(blocks) * na: off + nb * na] = -1.0
    elif objective == "value":
        c[n + extra] = -1.0
    w_lo = np.zeros(nb * na)
    for i, (t_i, _) in enumerate([*blocks, question]):
        if t_i is not None:
            need = np.zeros(na, bool)
            need[rows.col[rows.r < t_i - TOL]] = True
            w_lo[i * na:(i + 1) * na] = ~need
    col_lo = np.r_[rows.kmin, np.zeros(extra), [t_lo] if with_t else [], w_lo]
    col_hi = np.r_[rows.kmax, np.full(extra, INF), [top] if with_t else [], np.ones(nb * na)]
    integer = np.r_[np.ones(n, bool), np.zeros(extra + (1 if with_t else 0), bool), np.ones(nb * na, bool)]
    a = vstack(parts).tocsr()
    model = LinearModel(c, a, np.concatenate(lo), np.concatenate(hi), col_lo, col_hi, integer=integer)
    model.skip_presolve()
    return model, off


def count_levels(session: Session, row_dim: npt.NDArray[np.intp], n_dims: int, floors: Array, k: Array, t0: float,
                 stage_end: float) -> CountLevels:
    """The active dimensions' levels by counts from t0 (see the module text)."""
    del n_dims
    rows = _Rows(session, row_dim, floors, t0)
    eps = session.settings.quantum / 2
    top = float(np.max(rows.g[rows.act] - rows.lo_box[rows.act])) + 1.0
    blocks: list[tuple[float, int]] = []
    levels: list[tuple[float, int]] = []
    path: list[str] = []
    calls, cur_t, above = 0, t0, rows.n_active
    best = k

    while True:
        if time.perf_counter() >= stage_end:
            return CountLevels(best, floors.copy(), t0, tuple(blocks), tuple(levels), False, "time limit",
                               tuple(path), calls)
        # how many stay strictly above cur_t
        model, _ = _model(rows, blocks, 0, (cur_t + eps, 0), "count", top, cur_t)
        # no start point: given one, HiGHS 1.16 may report the optimum's objective with the start's point
        res = model.solve(stage_end - time.perf_counter())
        calls += 1
        c_best = int(np.sum(rows.margins(best) >= cur_t + eps - TOL))
        if res.x is not None:
            kk = np.clip(np.rint(res.x[:rows.n]), rows.kmin, rows.kmax)
            c_k = int(np.sum(rows.margins(kk) >= cur_t + eps - TOL))
            if rows.feasible(kk, blocks) and c_k > c_best:
                best, c_best = kk, c_k
        if res.status != "optimal" or c_best < round(-res.objective) - 1e-6:
            why = "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}"
            return CountLevels(best, floors.copy(), t0, tuple(blocks), tuple(levels), False, why, tuple(path), calls)
        levels.append((cur_t, above - c_best))
        path.append(f"leximin counts: {above - c_best} at {cur_t:.4g} steps")
        if c_best == 0:
            return CountLevels(best, floors.copy(), t0, tuple(blocks), tuple(levels), True, "", tuple(path), calls)
        above = c_best
        # the largest level those `above` dimensions reach together: raise τ while a point has `above`
        # margins ≥ τ + ε (feasibility MILPs with big-M of a few steps; the last one infeasible proves τ)
        tau = float(np.sort(rows.margins(best))[::-1][above - 1])
        while True:
            if time.perf_counter() >= stage_end:
                return CountLevels(best, floors.copy(), t0, tuple(blocks), tuple(levels), False, "time limit",
                                   tuple(path), calls)
            model, _ = _model(rows, blocks, 0, (tau + eps, above), "feasible", top, cur_t)
            res = model.solve(stage_end - time.perf_counter())
            calls += 1
            if res.status == "infeasible":
                break
            k_new = None if res.x is None else np.clip(np.rint(res.x[:rows.n]), rows.kmin, rows.kmax)
            t_k = -np.inf if k_new is None else float(np.sort(rows.margins(k_new))[::-1][above - 1])
            if k_new is None or not rows.feasible(k_new, blocks) or t_k < tau + eps - TOL:
                why = "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}"
                return CountLevels(best, floors.copy(), t0, tuple(blocks), tuple(levels), False, why, tuple(path),
                                   calls)
            best, tau = k_new, t_k
        blocks.append((tau, above))
        cur_t = tau


def count_least_norm(session: Session, row_dim: npt.NDArray[np.intp], counts: CountLevels, k: Array) -> LeastNorm:
    """Least Σ c k² subject to the floors, every active margin ≥ t0 and the count blocks (chord MILP)."""
    rows = _Rows(session, row_dim, counts.floors, counts.t0)
    n, cost = rows.n, session.rows.cost
    blocks = list(counts.blocks)
    if not rows.feasible(k, blocks):
        return LeastNorm(k, False, "no feasible start", 0.0, ("least norm: no feasible start",))
    top = float(np.max(rows.g[rows.act] - rows.lo_box[rows.act])) + 1.0 if rows.n_active else 0.0
    model, _ = _model(rows, blocks[:-1], n, blocks[-1] if blocks else (counts.t0, 0), "norm", top, 0.0)
    chords = [{0, int(abs(v)), max(int(abs(v)) - 1, 0)} for v in k]
    a_ch, rhs_ch = chord_rows([(i, j) for i, js in enumerate(chords) for j in sorted(js)], n, model.n_cols)
    model.add_rows(a_ch, np.full(rhs_ch.size, -INF), rhs_ch)
    model.set_costs(np.arange(n, 2 * n, dtype=np.int32), np.asarray(cost, dtype=float))

    def start(kk: Array) -> Array:
        m = rows.margins(kk)
        ts = [t for t, _ in blocks] if blocks else [counts.t0]
        return np.concatenate([kk, kk**2] + [(m >= t - TOL).astype(float) for t in ts])

    # no start point (best=None): given one, HiGHS 1.16 may hand it back with the optimum's objective
    out = lazy_chords(model, n, chords, cost, rows.kmin, rows.kmax, None, lambda kk: rows.feasible(kk, blocks),
                      start, session.clock.deadline, integer=True)
    best = k
    if out.best is not None and float(np.sum(cost * out.best**2)) <= float(np.sum(cost * k**2)):
        best = out.best
    return LeastNorm(best, out.proved, out.why, out.lower, ("least norm: chord MILP with the count blocks",))
