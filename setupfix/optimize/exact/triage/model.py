"""The triage's MILPs: dimensions kept in tolerance, leximin levels of their margins, in grid units.

Rows ``G k ≤ g`` of :func:`~setupfix.optimize.exact.lp_bound.margin_rows` (margin_j(k) = g_j − G_j k in
steps), each belonging to one dimension q (its margin m_q = min over its rows).  The dimensions split
in three:

* **held** — measured in tolerance (a finite no-harm floor f_q): hard rows m_q ≥ f_q, no binary;
  always kept (with no rows at all, a dimension is held trivially);
* **candidates** — the others that some point of the box brings into tolerance: a binary z_q
  ("kept"), rows G_j k + M_j z_q ≤ g_j + M_j, M_j = max_box G_j k − g_j;
* **lost** — no point of the box brings them in: given up whatever the correction.

A *level* (v, P) says "at most P kept dimensions have a margin below v": one binary y_q per kept
dimension that can fall below v (rows G_j k − M y_q + M z_q ≤ g_j − v + M, M = v − min_box m_j),
Σ y ≤ P; with P = 0 no y.  The levels v_1 < v_2 < … with P_1 = 0 < P_2 < … hold a point's sorted
kept margins at the leximin prefix found so far (positions P_i + 1 … are ≥ v_i).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array

from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.work import now

__all__ = [
    "KeptLevel",
    "TriageRows",
    "SLACK",
    "count_below",
    "least_listed",
    "listable",
    "listed_triage",
    "lp_starts",
]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: Rows hold to this many steps (HiGHS's feasibility tolerance is 1e-7 of their scale).
SLACK = 1e-7


@dataclass(frozen=True)
class KeptLevel:
    """At most ``below`` kept dimensions have a margin below ``value`` (steps)."""

    value: float
    below: int


@dataclass(frozen=True)
class _Block:
    """Rows of one level in a model: fixed threshold ``value``, or the model's column t (value None)."""

    dims: npt.NDArray[np.intp]
    value: float | None
    below: int | None  # None: no count row (the multiplicity objective counts them)
    binary: bool


class TriageRows:
    """The margin rows of one triage, with the split of the dimensions and the models' builders.

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); g : ndarray of shape (r,)
    row_dim : ndarray of int, shape (r,)
        Dimension (0 … n_dims−1) of each row.
    floor : ndarray of shape (n_dims,)
        No-harm floor in steps (−inf: not held).
    kmin, kmax, cost : ndarray of shape (n,)
    """

    def __init__(
        self,
        g_rows: Array,
        g: Array,
        row_dim: npt.NDArray[np.intp],
        floor: Array,
        kmin: Array,
        kmax: Array,
        cost: Array,
    ) -> None:
        self.G, self.g, self.row_dim = g_rows, g, row_dim
        self.n_dims, self.n = floor.size, g_rows.shape[1]
        self.kmin, self.kmax, self.cost = kmin, kmax, cost
        self.hi = np.sum(np.maximum(g_rows * kmin, g_rows * kmax), axis=1)  # max_box G_j k
        lo = np.sum(np.minimum(g_rows * kmin, g_rows * kmax), axis=1)
        self.low = g - self.hi  # least margin of each row in the box
        self.top = float(np.max(g - lo)) if g.size else 0.0  # no margin exceeds this
        has_rows = np.zeros(self.n_dims, bool)
        has_rows[row_dim] = True
        best = np.full(self.n_dims, np.inf)  # a dimension's rows each reachable (necessary for "can be in")
        np.minimum.at(best, row_dim, g - lo)
        self.held = np.isfinite(floor) | ~has_rows
        self.floor = np.where(np.isfinite(floor), floor, -np.inf)
        self.lost = ~self.held & (best < -SLACK)
        self.cand = np.flatnonzero(~self.held & ~self.lost)
        self.zcol = np.full(self.n_dims, -1)
        self.zcol[self.cand] = np.arange(self.cand.size)
        # hard rows: margin ≥ floor, never stricter than at k = 0 (the rounding of the deviations to the
        # quantum must not make "no correction" infeasible: recommend's harm check is exact)
        hr = self.held[row_dim] & has_rows[row_dim]
        self.hard_rows = np.flatnonzero(hr)
        self.hard_min = np.minimum(self.floor[row_dim[hr]], g[hr])
        self.keepable = np.flatnonzero(self.held | (self.zcol >= 0))
        # least margin of each row at a point that keeps its dimension: the hard floor (held), 0 (candidates)
        self.row_floor = np.zeros(g.size)
        self.row_floor[self.hard_rows] = np.maximum(self.low[self.hard_rows], self.hard_min)
        self.rowless = int(np.sum(~has_rows))
        seen = np.zeros(g.size, np.int64)  # the how-many-th row of its dimension each row is
        for q_rows in (
            np.split(np.argsort(row_dim, kind="stable"), np.flatnonzero(np.diff(np.sort(row_dim))) + 1)
            if g.size
            else []
        ):
            seen[q_rows] = np.arange(q_rows.size)
        self._groups = [(np.flatnonzero(seen == i), row_dim[seen == i]) for i in range(int(seen.max(initial=-1)) + 1)]

    def positions(self, kept: int) -> int:
        """Kept dimensions with a finite margin (those the leximin orders)."""
        return kept - self.rowless

    # --- points -------------------------------------------------------------------------------------------
    def margins(self, k: Array) -> Array:
        """Margin of every dimension at grid point k, steps (+inf without rows), shape (n_dims,)."""
        m = np.full(self.n_dims, np.inf)
        np.minimum.at(m, self.row_dim, self.g - self.G @ k)
        return m

    def hard_ok(self, k: Array) -> bool:
        slack = self.g[self.hard_rows] - self.G[self.hard_rows] @ k
        return bool(np.all(slack >= self.hard_min - 1e-6))

    def kept(self, k: Array) -> Mask:
        """Kept dimensions at k: the held ones and those in tolerance."""
        return self.held | (self.margins(k) >= -1e-6)

    def meets(self, k: Array, count: int, levels: tuple[KeptLevel, ...]) -> bool:
        """k keeps the held dimensions, ``count`` dimensions in all and every level."""
        if not self.hard_ok(k):
            return False
        kept = self.kept(k)
        if kept.sum() < count:
            return False
        m = self.margins(k)[kept]
        return all(int(np.sum(m < lv.value - 1e-6)) <= lv.below for lv in levels)

    def meets_many(self, ks: Array, count: int, levels: tuple[KeptLevel, ...]) -> Mask:
        """:meth:`meets` for grid points ks of shape (p, n), vectorised → bool ndarray of shape (p,)."""
        ok = np.all(self.g[self.hard_rows] - ks @ self.G[self.hard_rows].T >= self.hard_min - 1e-6, axis=1)
        m = self.margins_many(ks)
        kept = self.held[None, :] | (m >= -1e-6)
        ok &= kept.sum(axis=1) >= count
        for lv in levels:
            ok &= np.sum(kept & (m < lv.value - 1e-6), axis=1) <= lv.below
        out: Mask = ok
        return out

    def margins_many(self, ks: Array) -> Array:
        """Margins of every dimension at grid points ks (p, n), steps → shape (p, n_dims), +inf without rows."""
        slack = self.g[None, :] - ks @ self.G.T
        m = np.full((ks.shape[0], self.n_dims), np.inf)
        for rows, dims in self._groups:  # each group names a dimension at most once
            m[:, dims] = np.minimum(m[:, dims], slack[:, rows])
        return m

    def sorted_kept(self, k: Array) -> Array:
        m = self.margins(k)
        return np.sort(m[self.kept(k) & np.isfinite(m)])

    # --- models -------------------------------------------------------------------------------------------
    def _block(self, value: float | None, below: int | None) -> _Block:
        threshold = self.top if value is None else value
        low = np.full(self.n_dims, np.inf)
        np.minimum.at(low, self.row_dim, self.row_floor)
        dims = self.keepable[low[self.keepable] < threshold - SLACK]  # kept, the others never fall below
        return _Block(dims, value, below, below is None or below > 0)

    def model(
        self, count: int, levels: tuple[KeptLevel, ...], *, objective: str, at: float | None = None, t_lo: float = 0.0
    ) -> tuple[LinearModel, int]:
        """One MILP of the triage; returns the model and the offset of its z columns.

        Columns: k (n) | s (n, ``objective="norm"`` only) | z (candidates) | y of each block | t or nothing.

        count : int
            Dimensions to keep (ignored by ``"count"``, which finds it).
        objective : {"count", "level", "multiplicity", "norm"}
            max Σ z; max t ≥ ``t_lo`` with at most :func:`count_below` kept margins below t (the next
            leximin level); min #{kept: m < ``at``} (that level's multiplicity); min Σ c s (chords are
            added by the caller, :func:`~setupfix.optimize.exact.least_norm.chords.lazy_chords`).
        """
        n, nc = self.n, self.cand.size
        ns = n if objective == "norm" else 0
        blocks = [self._block(lv.value, lv.below) for lv in levels] if objective != "count" else []
        if objective == "level":
            blocks.append(self._block(None, count_below(levels)))
        elif objective == "multiplicity":
            assert at is not None
            blocks.append(self._block(at, None))
        z0 = n + ns
        ycols = []
        col = z0 + nc
        for b in blocks:
            ycols.append(col)
            col += b.dims.size if b.binary else 0
        tcol = col if objective == "level" else -1
        width = col + (1 if objective == "level" else 0)

        trip_r: list[npt.NDArray[np.generic]] = []
        trip_c: list[npt.NDArray[np.generic]] = []
        trip_v: list[Array] = []
        lo_parts: list[Array] = []
        hi_parts: list[Array] = []
        nrow = 0

        def add(
            rows: npt.NDArray[np.intp],
            coef_extra: list[tuple[npt.NDArray[np.intp], Array, Mask]],
            hi: Array,
            lo: Array | None = None,
        ) -> None:
            """Rows G[rows] k plus extra columns (cols, values, on which of the rows)."""
            nonlocal nrow
            sub = coo_array(self.G[rows]) if rows.size else coo_array((0, n))
            trip_r.append(sub.row + nrow)
            trip_c.append(sub.col)
            trip_v.append(sub.data)
            for cols, vals, on in coef_extra:
                trip_r.append(np.flatnonzero(on) + nrow)
                trip_c.append(cols)
                trip_v.append(vals)
            hi_parts.append(hi)
            lo_parts.append(np.full(rows.size, -INF) if lo is None else lo)
            nrow += rows.size

        def add_sum(cols: npt.NDArray[np.intp], lo: float, hi: float) -> None:
            nonlocal nrow
            trip_r.append(np.full(cols.size, nrow))
            trip_c.append(cols)
            trip_v.append(np.ones(cols.size))
            lo_parts.append(np.array([lo]))
            hi_parts.append(np.array([hi]))
            nrow += 1

        # hard rows of the held dimensions
        add(self.hard_rows, [], self.g[self.hard_rows] - self.hard_min)
        # candidates: in tolerance when z = 1
        crow = np.flatnonzero(self.zcol[self.row_dim] >= 0)
        big = np.maximum(self.hi[crow] - self.g[crow], 0.0)
        add(crow, [(z0 + self.zcol[self.row_dim[crow]], big, np.ones(crow.size, bool))], self.g[crow] + big)
        if objective != "count":
            add_sum(z0 + np.arange(nc), count - int(self.held.sum()), INF)
        for b, y0 in zip(blocks, ycols, strict=True):
            rows = np.flatnonzero(np.isin(self.row_dim, b.dims))
            value = self.top if b.value is None else b.value - SLACK
            big = np.maximum(value - self.low[rows], 0.0)  # z = 0: the row's least margin in the box
            big_y = np.maximum(value - self.row_floor[rows], 0.0)  # y = 1: its least margin when kept
            zc = self.zcol[self.row_dim[rows]]
            is_c = zc >= 0
            extra = [(z0 + zc[is_c], big[is_c], is_c)]
            if b.binary:
                extra.append((y0 + np.searchsorted(b.dims, self.row_dim[rows]), -big_y, np.ones(rows.size, bool)))
            if b.value is None:
                extra.append((np.full(rows.size, tcol), np.ones(rows.size), np.ones(rows.size, bool)))
                hi = self.g[rows] + np.where(is_c, big, 0.0)
            else:
                hi = self.g[rows] - value + np.where(is_c, big, 0.0)
            add(rows, extra, hi)
            if b.binary and b.below is not None:
                add_sum(y0 + np.arange(b.dims.size), -INF, float(b.below))

        a = csr_array(
            coo_array(
                (
                    np.concatenate(trip_v),
                    (np.concatenate(trip_r).astype(np.intp), np.concatenate(trip_c).astype(np.intp)),
                ),
                shape=(nrow, width),
            )
        )
        c = np.zeros(width)
        col_lo, col_hi = np.zeros(width), np.ones(width)
        col_lo[:n], col_hi[:n] = self.kmin, self.kmax
        integer = np.ones(width, bool)
        if ns:
            c[n : 2 * n] = self.cost
            col_lo[n : 2 * n], col_hi[n : 2 * n] = 0.0, INF
            integer[n : 2 * n] = False
        if objective == "count":
            c[z0 : z0 + nc] = -1.0
        elif objective == "level":
            c[tcol] = -1.0
            col_lo[tcol], col_hi[tcol] = t_lo, self.top
            integer[tcol] = False
        elif objective == "multiplicity":
            b = blocks[-1]
            c[ycols[-1] : ycols[-1] + b.dims.size] = 1.0
        self._layout = (blocks, ycols, tcol, z0, width)
        return LinearModel(
            c, a, np.concatenate(lo_parts), np.concatenate(hi_parts), col_lo, col_hi, integer=integer
        ), z0

    def start(self, k: Array, t: float | None = None) -> Array:
        """The last model's column vector at grid point k (feasible when k meets its levels)."""
        blocks, ycols, tcol, z0, width = self._layout
        x = np.zeros(width)
        x[: self.n] = k
        if z0 > self.n:
            x[self.n : 2 * self.n] = k**2
        m = self.margins(k)
        kept = self.kept(k)
        x[z0 : z0 + self.cand.size] = kept[self.cand]
        for b, y0 in zip(blocks, ycols, strict=True):
            if b.binary:
                value = (t if t is not None else self.top) if b.value is None else b.value
                x[y0 : y0 + b.dims.size] = kept[b.dims] & (m[b.dims] < value - SLACK)
        if tcol >= 0 and t is not None:
            x[tcol] = t
        return x


def lp_starts(t: TriageRows, time_limit: float) -> list[Array]:  # time_limit: for both LPs
    """Grid points for stage 1 from two LPs, rounded: the largest smallest margin of the held dimensions
    alone (what a re-solve on them would give), and of the held and every candidate dimension; the held
    rows keep half their row's |G| of room so that rounding k cannot push them below their floor."""
    from scipy.sparse import hstack as sparse_hstack

    out: list[Array] = []
    hard = t.hard_rows
    room = 0.5 * np.sum(np.abs(t.G[hard]), axis=1)
    hi_hard = t.g[hard] - t.hard_min - np.minimum(room, np.maximum(t.g[hard] - t.hard_min, 0.0))
    crow = np.flatnonzero(t.zcol[t.row_dim] >= 0)
    until = now() + time_limit
    for rows in (hard, np.r_[hard, crow]):
        if rows.size == 0 or until - now() <= 0:
            continue
        a = sparse_hstack([csr_array(t.G[rows]), csr_array(np.ones((rows.size, 1)))])
        a_hard = sparse_hstack([csr_array(t.G[hard]), csr_array((hard.size, 1))])
        from scipy.sparse import vstack as sparse_vstack

        model = LinearModel(
            np.r_[np.zeros(t.n), -1.0],
            sparse_vstack([a, a_hard]).tocsr(),
            np.full(rows.size + hard.size, -INF),
            np.r_[t.g[rows], hi_hard],
            np.r_[t.kmin, -INF],
            np.r_[t.kmax, t.top],
        )
        res = model.solve(until - now())
        if res.x is not None:
            k = np.clip(np.rint(res.x[: t.n]), t.kmin, t.kmax)
            if t.hard_ok(k):
                out.append(k)
    return out


def least_listed(
    t: TriageRows, lo: Array, hi: Array, count: int, levels: tuple[KeptLevel, ...], list_points: int
) -> Array | None:
    """The least Σ c k² grid point in the box [lo, hi] meeting ``count`` and ``levels``, ties to the
    lexicographically smallest k, by listing the box (None when points × rows exceed ``list_points``,
    ``ExactSettings.triage_list_points``: about 0.1 s of numpy at the default, or no point meets them)."""
    sizes = (hi - lo + 1).astype(np.int64)
    if np.prod(sizes.astype(float)) * max(t.g.size, 1) > list_points:
        return None
    axes = [np.arange(a, b + 1, dtype=float) for a, b in zip(lo, hi, strict=True)]
    ks = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, t.n)
    best: Array | None = None
    chunk = max(1, 4_000_000 // max(t.g.size, 1))
    for i in range(0, ks.shape[0], chunk):
        part = ks[i : i + chunk]
        ok = part[t.meets_many(part, count, levels)]
        if ok.size:
            cand = ok if best is None else np.vstack([best[None, :], ok])
            norm = cand**2 @ t.cost
            first = np.lexsort((*cand.T[::-1], norm))[0]  # least norm, then the smallest k lexicographically
            best = cand[first]
    return best


def listable(t: TriageRows, list_points: int) -> bool:
    """Whether the whole box is small enough for :func:`listed_triage` (points × rows ≤ ``list_points``)."""
    sizes = (t.kmax - t.kmin + 1).astype(float)
    return bool(np.prod(sizes) * max(t.g.size, 1) <= list_points)


def listed_triage(t: TriageRows, quantum: float, list_points: int) -> tuple[Array, int] | None:
    """The whole triage by listing the box (None when its points × rows exceed ``list_points``).

    Every grid point: the held dimensions kept (no harm), the most dimensions in tolerance, then the
    leximin of the kept margins as the MILPs' levels (each level's value, then the fewest kept margins
    within ``quantum``/2 above it, :func:`triage`), then the least
    Σ c k², then the lexicographically smallest k.  Returns the point and its count.
    """
    if not listable(t, list_points):
        return None
    axes = [np.arange(a, b + 1, dtype=float) for a, b in zip(t.kmin, t.kmax, strict=True)]
    ks = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, t.n)
    chunk = max(1, 4_000_000 // max(t.g.size, t.n_dims, 1))
    counts = np.full(ks.shape[0], -1)
    for i in range(0, ks.shape[0], chunk):
        part = ks[i : i + chunk]
        ok = np.all(t.g[t.hard_rows] - part @ t.G[t.hard_rows].T >= t.hard_min - 1e-6, axis=1)
        kept = t.held[None, :] | (t.margins_many(part) >= -1e-6)
        counts[i : i + chunk] = np.where(ok, kept.sum(axis=1), -1)
    if counts.max() < 0:
        return None
    ks = ks[counts == counts.max()]
    m = t.margins_many(ks)
    kept = t.held[None, :] | (m >= -1e-6)
    s = np.sort(np.where(kept & np.isfinite(m), m, np.inf), axis=1)
    alive, j = np.ones(ks.shape[0], bool), 0
    while j < s.shape[1] and np.isfinite(s[alive, j]).any():  # as the MILPs' levels: value, multiplicity
        value = s[alive, j].max()
        alive &= s[:, j] >= value - 1e-6
        below = np.sum(s < value + quantum / 2 - SLACK, axis=1)  # margins within the quantum above it
        alive &= below == below[alive].min()
        j = max(int(below[alive].min()), j + 1)
    ks = ks[alive]
    norm = ks**2 @ t.cost
    return ks[np.lexsort((*ks.T[::-1], norm))[0]], int(counts.max())


def count_below(levels: tuple[KeptLevel, ...]) -> int:
    """Kept dimensions a new level may leave below it: the last level's multiplicity."""
    return levels[-1].below if levels else 0
