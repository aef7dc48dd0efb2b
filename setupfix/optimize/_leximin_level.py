"""One leximin level on the register grid: max t with the fixed dimensions at their floors.

Grid units as in :mod:`setupfix.optimize._session`.  With floors v_q for the fixed
dimensions and the others active, the level is

    t_i = max t  over integer k in the box  s.t.  G_j k + t ≤ g_j  (rows of active dimensions),
                                                  G_j k ≤ g_j − v_q(j)  (rows of fixed ones).

Proof, cheapest first (as :func:`~setupfix.optimize._grid_optimum.grid_optimum` for level 1):
the LP bound t_LP; a grid point (the previous level's, the LP point rounded) reaching it; the
ascent on rounded rows: the rows rounded at t(best) + ε hold every grid point better than the
best one (:func:`~setupfix.optimize._grid.rounded_rhs`), so an LP proving them empty proves the
level, and where every row has at most two ±1 entries that a flip of columns makes opposite
(:func:`~setupfix.optimize._grid.is_network`, totally unimodular) a feasible LP's vertex is itself
a better grid point; else a feasibility MILP decides; last (after ``level_steps`` ascents) the
MILP "max t, k integer" bracketed by the best point and the bound.

One HiGHS model per solve holds [G | a] (a_j = 1 for active rows, 0 for fixed ones), changed in
place from level to level (:class:`LevelModel`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize._grid import TOL, rounded_rhs
from setupfix.optimize._highs import INF, LinearModel
from setupfix.optimize._session import GridRows, Session

__all__ = ["Certificates", "LevelModel", "LevelValue", "dim_margins"]

Array = npt.NDArray[np.float64]


def dim_margins(g_rows: Array, g: Array, k: Array, row_dim: npt.NDArray[np.intp], n_dims: int) -> Array:
    """Margin of each dimension at k: the least of its rows' ``g_j − G_j k`` (inf: no row) — shape (n_dims,)."""
    out = np.full(n_dims, np.inf)
    np.minimum.at(out, row_dim, g - g_rows @ k)
    return out


@dataclass(frozen=True)
class LevelValue:
    """A level: its value t [steps] at the grid point k, the LP bound t_lp and the LP's row weights y (r,)."""

    t: float
    k: Array
    t_lp: float
    y: Array | None
    stop: str | None = None
    path: tuple[str, ...] = ()
    calls: int = 0


@dataclass(frozen=True)
class Certificates:
    """Row weights to check by weak duality: (weights (r,), rhs (r,), floor of the active sum, rounded?)."""

    g_rows: Array
    kmin: Array
    kmax: Array
    certificates: tuple[tuple[Array, Array, float, bool], ...]


class LevelModel:
    """The level LP of one solve, [G | a] in one HiGHS model, and the level proofs on it."""

    def __init__(self, session: Session, row_dim: npt.NDArray[np.intp], n_dims: int) -> None:
        self.session = session
        self.rows: GridRows = session.rows
        self.row_dim = row_dim
        self.n_dims = n_dims
        r, n = self.rows.g_rows.shape
        self.n = n
        self._lp = LinearModel(np.r_[np.zeros(n), -1.0], self.rows.derived.lp_matrix, np.full(r, -INF), self.rows.g,
                               np.r_[self.rows.kmin, -INF], np.r_[self.rows.kmax, INF])
        self._coef = np.ones(r)
        # rows keyed by a random integer projection: equal (or opposite) rows, equal (or opposite) keys
        weights = np.random.default_rng(0).integers(1, 2**20, n).astype(float)
        self._key = self.rows.g_rows @ weights

    def same_vector(self, rows_mask: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
        """Integer rows equal or opposite to one of ``rows_mask``'s integer rows (checked, not only keyed).

        When G_j k is the same at every grid point of a level set, so is G_j' k for G_j' = ±G_j.
        """
        rows = self.rows
        out = np.zeros(rows_mask.size, bool)
        integer = rows.d > 0
        for j in np.flatnonzero(rows_mask & integer):
            cand = np.flatnonzero(integer & ~out & (np.abs(self._key) == abs(self._key[j])))
            same = np.all(rows.g_rows[cand] == rows.g_rows[j], axis=1) | np.all(
                rows.g_rows[cand] == -rows.g_rows[j], axis=1)
            out[cand[same]] = True
        return out

    # -- the model --------------------------------------------------------------------------------
    def _floors(self, v: Array) -> Array:
        """Per row: the floor of its dimension (NaN: active)."""
        return v[self.row_dim]

    def _pattern(self, v: Array) -> None:
        """t's coefficient 1 on active rows, 0 on fixed ones (changed in place where it differs)."""
        want = np.where(np.isnan(self._floors(v)), 1.0, 0.0)
        changed = np.flatnonzero(want != self._coef)
        if changed.size:
            self._lp.set_column(self.n, changed, want[changed])
        self._coef = want

    def rhs(self, v: Array) -> Array:
        """g_j on active rows, g_j − v_q(j) on fixed ones (+inf: a dimension left out)."""
        f = self._floors(v)
        return np.where(np.isnan(f), self.rows.g, self.rows.g - f)

    def _solve(self, hi: Array, time_limit: float) -> tuple[str, Array | None, Array | None]:
        self._lp.set_row_bounds(np.full(hi.size, -INF), np.where(np.isfinite(hi), hi, INF))
        res = self._lp.solve(max(time_limit, 1e-3))
        y = None if res.row_dual is None else np.maximum(-res.row_dual, 0.0)
        return res.status if res.status != "error" else f"HiGHS: {res.detail}", res.x, y

    def _feasible(self, b: Array, time_limit: float) -> tuple[str, Array | None]:
        """Whether G k ≤ b has a point in the box (t fixed at 0): status and HiGHS's (vertex) point."""
        col = np.array([self.n], dtype=np.int32)
        self._lp.set_col_bounds(col, np.zeros(1), np.zeros(1))
        try:
            status, x, _ = self._solve(b, time_limit)
        finally:
            self._lp.set_col_bounds(col, np.array([-INF]), np.array([INF]))
        return status, None if x is None else x[:self.n]

    # -- evaluation -------------------------------------------------------------------------------
    def level_of(self, k: Array, v: Array) -> float:
        """min over active rows of g_j − G_j k, or −inf if a fixed row is below its floor."""
        f = self._floors(v)
        m = self.rows.g - self.rows.g_rows @ k
        fixed = ~np.isnan(f)
        if np.any(m[fixed] < f[fixed] - TOL):
            return -np.inf
        act = m[~fixed]
        return float(act.min()) if act.size else np.inf

    def rounded(self, v: Array, tau: float) -> Array:
        """Rows rounded at τ (active) and at their floors (fixed): they hold every grid point of the level set."""
        f = self._floors(v)
        level = np.where(np.isnan(f), tau, f)
        fin = np.isfinite(level)
        b = np.full(level.size, np.inf)
        b[fin] = rounded_rhs(self.rows.g[fin], self.rows.d[fin], self.rows.zero[fin], level[fin])
        return b

    # -- the level --------------------------------------------------------------------------------
    def value(self, v: Array, k_prev: Array, stage_end: float) -> LevelValue:
        """The proved level t_i (or the best point when stopped) — see the module text."""
        rows, s = self.rows, self.session.settings
        self._pattern(v)
        status, x, y = self._solve(self.rhs(v), stage_end - time.perf_counter())
        if status != "optimal" or x is None:
            reason = "time limit" if status == "time_limit" else status
            return LevelValue(self.level_of(k_prev, v), k_prev, np.inf, None, reason, (), 1)
        t_lp = float(x[-1])
        k_best, t_best = k_prev, self.level_of(k_prev, v)
        k_round = np.clip(np.rint(x[:-1]), rows.kmin, rows.kmax)
        t_round = self.level_of(k_round, v)
        if t_round > t_best:
            k_best, t_best = k_round, t_round
        calls, path = 1, list[str]()
        if t_best >= t_lp - TOL:
            return LevelValue(t_best, k_best, t_lp, y, None, (), calls)
        # ascent: a grid point with every active margin ≥ t(best) + ε on the rounded rows (an LP, a feasibility
        # MILP), until none is left (proved) — the rounded LP point is usually at or next to the level
        f = self._floors(v)
        eps = s.quantum / 2
        for _ in range(s.level_steps):
            if time.perf_counter() >= stage_end:
                return LevelValue(t_best, k_best, t_lp, y, "time limit", tuple(path), calls)
            found = self.point_above(np.where(np.isnan(f), t_best + eps, f), stage_end)
            calls += 1
            if found is False:
                path.append("leximin: no grid point above the best one (rounded rows)")
                return LevelValue(t_best, k_best, t_lp, y, None, tuple(path), calls)
            if found is None or isinstance(found, bool) or self.level_of(found, v) < t_best + eps - 1e-9:
                break
            k_best, t_best = found, self.level_of(found, v)
            if t_best >= t_lp - TOL:
                path.append("leximin: a grid point of the rounded rows reaches the LP bound")
                return LevelValue(t_best, k_best, t_lp, y, None, tuple(path), calls)
        upper = t_lp
        return self._milp(v, k_best, t_best, upper, t_lp, y, stage_end, path, calls)

    def _milp(self, v: Array, k_best: Array, t_best: float, upper: float, t_lp: float, y: Array | None,
              stage_end: float, path: list[str], calls: int) -> LevelValue:
        """max t, k integer, t ∈ [t(best point), upper], started from the best point."""
        rows = self.rows
        r, n = rows.g_rows.shape
        hi = self.rhs(v)
        a = np.hstack([rows.g_rows, self._coef[:, None]])
        model = LinearModel(np.r_[np.zeros(n), -1.0], a, np.full(r, -INF), np.where(np.isfinite(hi), hi, INF),
                            np.r_[rows.kmin, t_best], np.r_[rows.kmax, upper],
                            integer=np.r_[np.ones(n, bool), False])
        res = model.solve(stage_end - time.perf_counter(), np.r_[k_best, t_best])
        calls += 1
        if res.x is not None and self.level_of(np.clip(np.rint(res.x[:-1]), rows.kmin, rows.kmax), v) < (
                -res.objective - 1e-6):  # HiGHS 1.16 handed back the start with the optimum's objective
            res = model.solve(stage_end - time.perf_counter())
            calls += 1
        path.append(f"leximin: level MILP ({res.status})")
        if res.x is not None:
            k = np.clip(np.rint(res.x[:-1]), rows.kmin, rows.kmax)
            t_k = self.level_of(k, v)
            if t_k > t_best:
                k_best, t_best = k, t_k
        stop = None
        if res.status != "optimal":
            stop = "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}"
        return LevelValue(t_best, k_best, t_lp, y, stop, tuple(path), calls)

    def can_rise(self, v: Array, q: int, t: float, eps: float, stage_end: float) -> bool | None:
        """Whether a grid point of the level set (active ≥ t, fixed ≥ floors) has M_q ≥ t + ε.

        False is a proof (the LP or MILP of the rounded rows with q's rows at t + ε is infeasible);
        None: the limit or HiGHS stopped the test.
        """
        f = self._floors(v).copy()
        f[np.isnan(f)] = t
        f[self.row_dim == q] = t + eps
        found = self.point_above(f, stage_end)
        return None if found is None else found is not False

    def alone_at(self, v: Array, q: int, t: float, eps: float, stage_end: float) -> Array | bool | None:
        """A grid point with every active dimension but q at t + ε or more (q ≥ t, fixed ≥ floors);
        False: proved none; None: stopped."""
        f = self._floors(v).copy()
        f[np.isnan(f)] = t + eps
        f[self.row_dim == q] = t
        return self.point_above(f, stage_end)

    def point_above(self, f: Array, stage_end: float) -> Array | bool | None:
        """A grid point with every row's margin ≥ f_j (shape (r,), −inf: no floor); False: proved none
        (the LP or MILP of the rounded rows is infeasible); None: the limit or HiGHS stopped it."""
        rows = self.rows
        fin = np.isfinite(f)
        b = np.full(f.size, np.inf)
        b[fin] = rounded_rhs(rows.g[fin], rows.d[fin], rows.zero[fin], f[fin])

        def meets(k: Array) -> bool:
            return bool(np.all((rows.g - rows.g_rows @ k)[fin] >= f[fin] - 1e-9))

        if rows.all_integer:
            feas, kx = self._feasible(b, stage_end - time.perf_counter())
            if feas == "infeasible":
                return False
            if feas != "optimal":
                return None
            if kx is not None:
                k = np.clip(np.rint(kx), rows.kmin, rows.kmax)
                if meets(k):
                    return k
        res = LinearModel(np.zeros(self.n), rows.g_rows[fin], np.full(int(fin.sum()), -INF), b[fin], rows.kmin,
                          rows.kmax, integer=np.ones(self.n, bool)).solve(stage_end - time.perf_counter())
        if res.status == "infeasible":
            return False
        if res.x is not None:
            k = np.clip(np.rint(res.x), rows.kmin, rows.kmax)
            return k if meets(k) else None
        return None

    # -- certificates of saturation ---------------------------------------------------------------
    def certify(self, level: LevelValue, v: Array) -> Certificates:
        """The level LP's weights (rhs g on active rows, g − v on fixed rows; active floor t)."""
        certs: tuple[tuple[Array, Array, float, bool], ...] = ()
        if level.y is not None:
            rhs = self.rhs(v)
            y = np.where(np.isfinite(rhs), level.y, 0.0)
            total = float(y[np.isnan(self._floors(v))].sum())
            if total > 0:
                certs = ((y, np.where(np.isfinite(rhs), rhs, 0.0), level.t, False),)
        return Certificates(self.rows.g_rows, self.rows.kmin, self.rows.kmax, certs)

    def certify_rounded(self, level: LevelValue, v: Array, stage_end: float) -> Certificates:
        """max s s.t. G_j k + s ≤ b_j (active), G_j k ≤ b_j (fixed), b rounded at t: its weights pin rows."""
        self._pattern(v)
        b = self.rounded(v, level.t)
        status, _, y = self._solve(b, stage_end - time.perf_counter())
        certs: tuple[tuple[Array, Array, float, bool], ...] = ()
        if status == "optimal" and y is not None:
            y = np.where(np.isfinite(b), y, 0.0)
            certs = ((y, np.where(np.isfinite(b), b, 0.0), 0.0, True),)
        return Certificates(self.rows.g_rows, self.rows.kmin, self.rows.kmax, certs)
