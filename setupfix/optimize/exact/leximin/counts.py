"""Leximin by counts: the generic, always-correct way past a discrete conflict (MILPs with binaries).

Grid units as in :mod:`setupfix.optimize.exact.session`; dimensions fixed with floors v_q stay so,
every *active* dimension has margin ≥ t₀ (the level where the progressive filling of
:mod:`setupfix.optimize.exact.leximin.levels` stopped).  The sorted margins of the active dimensions form a
step function with values t₀ = t₁ < t₂ < … and N_i = how many are ≥ t_i; a grid point is at
least as good (leximin) iff #{q : M_q ≥ t_i} ≥ N_i for every i.  So, in turn:

* **count** at t_i: max Σ w_q, w_q = 1 ⇒ M_q ≥ t_i + ε (binaries w, big-M rows from the box),
  subject to the blocks found so far — N_{i+1} = the optimum; none above: done;
* **value**: max t s.t. Σ w_q ≥ N_{i+1}, w_q = 1 ⇒ M_q ≥ t — t_{i+1} = the optimum;
  the block (t_{i+1}, N_{i+1}) joins the constraints.

The least norm among the leximin-optimal points is the chord MILP of Σ c k² (chords of k² added
lazily, :func:`~setupfix.optimize.exact.least_norm.chords.lazy_chords`) with the same blocks.  Each MILP is
solved to a zero gap; the limit stops the chain with the best point found.

On integer rows the base rows are rounded (G_j k ≤ ⌊g_j − t0⌋ on the row's lattice), so a row's
margin is at least its lattice value r_j at or above t0 wherever they hold: a block at level t
needs big-M rows only where r_j < t and binaries only for their dimensions; every other active
dimension is above t anyway and enters the counts as a constant.  At 180 × 2,000 the first count
has 208 binaries instead of 1,965 (``bench/results/leximin_shop_trace.txt``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array, hstack, vstack

from setupfix.optimize.exact.grid import TOL, rounded_rhs
from setupfix.optimize.exact.highs import INF, LinearModel, Solve
from setupfix.optimize.exact.least_norm.chords import chord_rows, lazy_chords
from setupfix.optimize.exact.least_norm.grid import LeastNorm
from setupfix.optimize.exact.session import Session
from setupfix.optimize.exact.work import now

__all__ = ["CountLayout", "CountLevels", "CountRows", "CountRuns", "count_least_norm", "count_levels", "count_model"]

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
    longest : float
        The longest of those MILPs [s] (the least norm's chord MILP starts only with more time left).
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
    longest: float


class CountRuns:
    """A chain's MILP runs: the next starts only with more time left than the longest so far took.

    HiGHS looks at its clock (and the interrupt callback) only between the cut rounds of a MILP's
    root node, and the chain's MILPs grow block by block (the previous code's solves ran to 20.6 s of a
    20 s limit at 180 × 2,000, ``bench/results/exact_scaling_leximin_20s.txt``).  Stopping the chain
    before a run that cannot end in time keeps the stage within its share of the limit.
    """

    def __init__(self, stage_end: float) -> None:
        self.stage_end, self.longest, self.calls = stage_end, 0.0, 0

    def room(self) -> bool:
        """Whether more time than the longest run so far is left before the stage's end."""
        return self.stage_end - now() > self.longest

    def solve(self, model: LinearModel) -> Solve:
        began = now()
        res = model.solve(self.stage_end - began)
        self.longest = max(self.longest, now() - began)
        self.calls += 1
        return res


class CountRows:
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
        self.g_act = self.g[self.act]
        level = np.where(self.act, t0, np.where(self.fix, f, -np.inf))
        self.base_hi = np.where(self.act | self.fix, rounded_rhs(self.g, rows.d, rows.zero, level), np.inf)
        # the least margin an active row can have over the base rows (its lattice value at or above t0)
        self.r = np.where(rows.zero, self.g, self.g - self.base_hi)[self.act]
        self.keep = self.act | self.fix
        self.f = f
        self.t0 = t0
        self.link = session.settings.link_count_blocks  # nested blocks' binaries linked
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

    def block(self, t: float | None, top: float) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], csr_array, Array]:
        """The big-M rows G_j k (+ t) + M w_q(j) ≤ g_j − t + M of level t: (active rows, binaries, matrix, rhs).

        Only the rows whose lattice value at or above t0 (``r``) is below t get one, and only their
        dimensions a binary: every other row has margin ≥ t wherever the base rows hold, so its
        dimension counts as above t (t None, the value question: every row and dimension).
        M = level − t0: with w = 0 the row is the base row G_j k ≤ g_j − t0 (t ≤ ``top`` for the
        value question), so the big-M is a few steps, not the box's span.  Returns the rows (positions
        among the active rows), the dimensions with a binary (positions among the active ones,
        sorted), the matrix on those binaries and the right-hand sides.
        """
        # every active row already has G_j k ≤ g_j − t0 (the base rows): M_j = level − t0 relaxes it to that
        level = top if t is None else t
        at = np.arange(self.r.size) if t is None else np.flatnonzero(self.r < t - TOL)
        dims = np.unique(self.col[at])
        big = np.full(at.size, max(level - self.t0, 0.0))
        rhs = self.g_act[at] + big - (0.0 if t is None else t)
        w = csr_array(
            coo_array((big, (np.arange(at.size), np.searchsorted(dims, self.col[at]))), shape=(at.size, dims.size))
        )
        return at, dims, w, rhs


@dataclass(frozen=True)
class CountLayout:
    """Which binaries a count MILP has: block i's (the question last) on ``dims[i]`` (positions among the
    active dimensions), in that order after the other columns; the others of a block are above its level anyway."""

    dims: tuple[npt.NDArray[np.intp], ...]
    n_active: int

    def above_anyway(self, i: int) -> int:
        """Active dimensions with no binary in block i (margin ≥ its level wherever the base rows hold)."""
        return self.n_active - int(self.dims[i].size)

    def binaries(self, m: Array, levels: list[float]) -> Array:
        """The binaries' values at a grid point with active margins m (shape (n_active,)), block by block."""
        return np.concatenate([(m[d] >= t - TOL).astype(float) for d, t in zip(self.dims, levels, strict=True)])


def count_model(
    rows: CountRows,
    blocks: list[tuple[float, int]],
    extra: int,
    question: tuple[float | None, int],
    objective: str,
    top: float,
    t_lo: float,
) -> tuple[LinearModel, CountLayout]:
    """The MILP: columns k (n), s (``extra``: the norm's), [t], the blocks' binaries and the question's."""
    n = rows.n
    with_t = question[0] is None
    off = n + extra + (1 if with_t else 0)
    made = [rows.block(t_i, top) for t_i, _ in [*blocks, question]]
    starts = tuple(int(v) for v in off + np.cumsum([0] + [d.size for _, d, _, _ in made[:-1]]))
    width = off + sum(d.size for _, d, _, _ in made)
    layout = CountLayout(tuple(d for _, d, _, _ in made), rows.n_active)
    parts, lo, hi = [], [], []
    g_keep = csr_array(rows.g_rows[rows.keep])
    parts.append(hstack([g_keep, csr_array((g_keep.shape[0], width - n))]))
    lo.append(np.full(g_keep.shape[0], -INF))
    hi.append(rows.base_hi[rows.keep])
    g_act = rows.g_rows[rows.act]
    for i, ((t_i, c_i), (at, dims, wmat, rhs)) in enumerate(zip([*blocks, question], made, strict=True)):
        cols = [csr_array(g_act[at]), csr_array((at.size, extra))]
        if with_t:
            cols.append(csr_array(np.ones((at.size, 1))) if t_i is None else csr_array((at.size, 1)))
        cols += [csr_array((at.size, starts[i] - off)), wmat, csr_array((at.size, width - starts[i] - dims.size))]
        parts.append(hstack(cols))
        lo.append(np.full(at.size, -INF))
        hi.append(rhs)
        if i < len(blocks) or objective != "count":
            count = np.zeros(width)
            count[starts[i] : starts[i] + dims.size] = 1.0
            parts.append(csr_array(count[None, :]))
            lo.append(np.array([float(c_i - layout.above_anyway(i))]))
            hi.append(np.array([INF]))
    if len(made) > 1 and rows.link:  # nested blocks (t rises block by block): w_i,q = 1 ⇒ M_q ≥ t_i ≥ t_(i−1), so
        # w_i,q ≤ w_(i−1),q is valid (raise w_(i−1),q) and cuts the LP relaxation and symmetric branches;
        # a dimension with no binary in block i − 1 is above t_(i−1) anyway (w_(i−1),q = 1: no row)
        rows_i, cols_i, vals = [], [], []
        n_link = 0
        for i in range(1, len(made)):
            both, here, there = np.intersect1d(layout.dims[i], layout.dims[i - 1], return_indices=True)
            link = n_link + np.arange(both.size)
            rows_i.append(np.r_[link, link])
            cols_i.append(np.r_[starts[i] + here, starts[i - 1] + there])
            vals.append(np.r_[np.ones(both.size), -np.ones(both.size)])
            n_link += both.size
        parts.append(
            csr_array(
                coo_array(
                    (np.concatenate(vals), (np.concatenate(rows_i), np.concatenate(cols_i))), shape=(n_link, width)
                )
            )
        )
        lo.append(np.full(n_link, -INF))
        hi.append(np.zeros(n_link))
    c = np.zeros(width)
    if objective == "count":
        c[starts[-1] :] = -1.0
    elif objective == "value":
        c[n + extra] = -1.0
    n_bin = width - off
    col_lo = np.r_[rows.kmin, np.zeros(extra), [t_lo] if with_t else [], np.zeros(n_bin)]
    col_hi = np.r_[rows.kmax, np.full(extra, INF), [top] if with_t else [], np.ones(n_bin)]
    integer = np.r_[np.ones(n, bool), np.zeros(extra + (1 if with_t else 0), bool), np.ones(n_bin, bool)]
    a = vstack(parts).tocsr()
    model = LinearModel(c, a, np.concatenate(lo), np.concatenate(hi), col_lo, col_hi, integer=integer)
    model.skip_presolve()
    return model, layout


def count_levels(
    session: Session, row_dim: npt.NDArray[np.intp], n_dims: int, floors: Array, k: Array, t0: float, stage_end: float
) -> CountLevels:
    """The active dimensions' levels by counts from t0 (see the module text)."""
    del n_dims
    rows = CountRows(session, row_dim, floors, t0)
    eps = session.settings.quantum / 2
    top = float(np.max(rows.g[rows.act] - rows.lo_box[rows.act])) + 1.0
    blocks: list[tuple[float, int]] = []
    levels: list[tuple[float, int]] = []
    path: list[str] = []
    runs, cur_t, above = CountRuns(stage_end), t0, rows.n_active
    best = k

    def out(proved: bool, why: str) -> CountLevels:
        return CountLevels(
            best, floors.copy(), t0, tuple(blocks), tuple(levels), proved, why, tuple(path), runs.calls, runs.longest
        )

    while True:
        if not runs.room():
            return out(False, "time limit")
        # how many stay strictly above cur_t
        model, layout = count_model(rows, blocks, 0, (cur_t + eps, 0), "count", top, cur_t)
        # no start point: given one, HiGHS 1.16 may report the optimum's objective with the start's point
        res = runs.solve(model)
        c_best = int(np.sum(rows.margins(best) >= cur_t + eps - TOL))
        if res.x is not None:
            kk = np.clip(np.rint(res.x[: rows.n]), rows.kmin, rows.kmax)
            c_k = int(np.sum(rows.margins(kk) >= cur_t + eps - TOL))
            if rows.feasible(kk, blocks) and c_k > c_best:
                best, c_best = kk, c_k
        if res.status != "optimal" or c_best < round(-res.objective) + layout.above_anyway(len(blocks)) - 1e-6:
            return out(False, "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
        levels.append((cur_t, above - c_best))
        path.append(f"leximin counts: {above - c_best} at {cur_t:.4g} steps")
        if c_best == 0:
            return out(True, "")
        above = c_best
        # the largest level those `above` dimensions reach together: raise τ while a point has `above`
        # margins ≥ τ + ε (feasibility MILPs with big-M of a few steps; the last one infeasible proves τ)
        tau = float(np.sort(rows.margins(best))[::-1][above - 1])
        while True:
            if not runs.room():
                return out(False, "time limit")
            model, _ = count_model(rows, blocks, 0, (tau + eps, above), "feasible", top, cur_t)
            res = runs.solve(model)
            if res.status == "infeasible":
                break
            k_new = None if res.x is None else np.clip(np.rint(res.x[: rows.n]), rows.kmin, rows.kmax)
            t_k = -np.inf if k_new is None else float(np.sort(rows.margins(k_new))[::-1][above - 1])
            if k_new is None or not rows.feasible(k_new, blocks) or t_k < tau + eps - TOL:
                return out(False, "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
            best, tau = k_new, t_k
        blocks.append((tau, above))
        cur_t = tau


def count_least_norm(session: Session, row_dim: npt.NDArray[np.intp], counts: CountLevels, k: Array) -> LeastNorm:
    """Least Σ c k² subject to the floors, every active margin ≥ t0 and the count blocks (chord MILP)."""
    rows = CountRows(session, row_dim, counts.floors, counts.t0)
    n, cost = rows.n, session.rows.cost
    blocks = list(counts.blocks)
    if not rows.feasible(k, blocks):
        return LeastNorm(k, False, "no feasible start", 0.0, ("least norm: no feasible start",))
    if session.clock.deadline - now() <= counts.longest:  # it would not end in time (:class:`CountRuns`)
        return LeastNorm(
            k,
            False,
            "time limit",
            0.0,
            (f"least norm: less work left than a count MILP took ({counts.longest:.0f} units): the counts' point",),
        )
    top = float(np.max(rows.g[rows.act] - rows.lo_box[rows.act])) + 1.0 if rows.n_active else 0.0
    model, layout = count_model(rows, blocks[:-1], n, blocks[-1] if blocks else (counts.t0, 0), "norm", top, 0.0)
    chords = [{0, int(abs(v)), max(int(abs(v)) - 1, 0)} for v in k]
    a_ch, rhs_ch = chord_rows([(i, j) for i, js in enumerate(chords) for j in sorted(js)], n, model.n_cols)
    model.add_rows(a_ch, np.full(rhs_ch.size, -INF), rhs_ch)
    model.set_costs(np.arange(n, 2 * n, dtype=np.int32), np.asarray(cost, dtype=float))

    def start(kk: Array) -> Array:
        return np.concatenate([kk, kk**2, layout.binaries(rows.margins(kk), [t for t, _ in blocks] or [counts.t0])])

    # no start point (best=None): given one, HiGHS 1.16 may hand it back with the optimum's objective
    out = lazy_chords(
        model,
        n,
        chords,
        cost,
        rows.kmin,
        rows.kmax,
        None,
        lambda kk: rows.feasible(kk, blocks),
        start,
        session.clock.deadline,
        integer=True,
    )
    best = k
    if out.best is not None and float(np.sum(cost * out.best**2)) <= float(np.sum(cost * k**2)):
        best = out.best
    return LeastNorm(best, out.proved, out.why, out.lower, ("least norm: chord MILP with the count blocks",))
