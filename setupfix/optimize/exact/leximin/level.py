"""One leximin level on the register grid: max t with the fixed dimensions at their floors.

Grid units as in :mod:`setupfix.optimize.exact.session`.  With floors v_q for the fixed
dimensions and the others active, the level is

    t_i = max t  over integer k in the box  s.t.  G_j k + t ≤ g_j  (rows of active dimensions),
                                                  G_j k ≤ g_j − v_q(j)  (rows of fixed ones).

Proof, cheapest first (:meth:`LevelModel.step`): a grid point's own level t is the level when
the rows rounded at t + ε (:func:`~setupfix.optimize.exact.grid.rounded_rhs`) hold no point of the box
— every grid point better than it meets them — shown by a Farkas certificate from NNLS (small
problems) or by the duals of the level LP on the rounded rows; each certificate is checked in
numpy and its weights also pin rows (:mod:`setupfix.optimize.exact.leximin.pins`).  Otherwise the
next point to try is NNLS's least-distance point of those rows, rounded (small problems, no LP),
else the level LP's point, rounded (:meth:`LevelModel.round_best`).  What the steps leave:
:meth:`LevelModel.value` — the LP bound, the ascent on rounded rows (NNLS or an LP, feasibility
MILPs last: :func:`~setupfix.optimize.exact.leximin.pins.point_above`), last the MILP "max t, k integer"
bracketed by the best point and the bound.

One warm-started HiGHS model per solve holds the level LP with a column u_q per dimension (only
bounds change from level to level, :attr:`LevelModel._lp`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.farkas import farkas_or_point
from setupfix.optimize.exact.grid import TOL, rounded_rhs
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.leximin.pins import Certificates, LevelStep, best_rounding, level_bound, point_above
from setupfix.optimize.exact.session import GridRows, Session
from setupfix.optimize.exact.work import now

__all__ = ["SPREAD", "LevelModel", "LevelValue"]

#: Weight of Σ u_q (active margins) beside t in the level LP where a step proves the level: small enough to
#: leave t at its maximum in practice; among the points at the level it takes one with the others high.
SPREAD = 1e-4

Array = npt.NDArray[np.float64]

#: Ascents of one step by the rounded least-distance point of NNLS (no LP) before the level LP's point is rounded.
NNLS_ASCENTS = 3


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
    certificates: Certificates | None = None  # the rounded rows' weights, when a step proved the level


def _grouping(
    g_rows: Array, row_dim: npt.NDArray[np.intp]
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.intp], bool, Array]:
    """The rows grouped by dimension (order, group starts for reduceat, each group's dimension), whether
    a dimension has more than two rows (a position zone's polygon; one-axis problems have at most two),
    and the rows keyed by a random integer projection (equal or opposite rows, equal or opposite keys)."""
    order = np.argsort(row_dim, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(row_dim[order]) != 0])
    weights = np.random.default_rng(0).integers(1, 2**20, g_rows.shape[1]).astype(float)
    out = (
        order,
        starts,
        row_dim[order][starts],
        bool(row_dim.size and np.bincount(row_dim).max() > 2),
        g_rows @ weights,
    )
    for a in (out[0], out[1], out[2], out[4]):
        a.flags.writeable = False
    return out


class LevelModel:
    """The level LP of one solve, [G | a] in one HiGHS model, and the level proofs on it."""

    def __init__(self, session: Session, row_dim: npt.NDArray[np.intp], n_dims: int) -> None:
        self.session = session
        self.rows: GridRows = session.rows
        self.row_dim = row_dim
        self.n_dims = n_dims
        n = self.rows.g_rows.shape[1]
        self.n = n
        self._model: LinearModel | None = None  # the level LP, built on first use
        self._cost = np.zeros(n_dims)  # its costs on u
        self.order, self.starts, self.dims, self.polygons, self.key = self.rows.memo(
            ("level rows", row_dim.tobytes()), lambda: _grouping(self.rows.g_rows, row_dim)
        )

    @property
    def _lp(self) -> LinearModel:
        """max t  s.t.  G_j k + u_q(j) ≤ rhs_j,  t − u_q ≤ 0 (active q),  k in the box — built on first use.

        One column u_q per dimension: active, u_q is free and its row holds it at or above t; fixed,
        its row is free and u_q ≥ its floor (so G_j k ≤ rhs_j − floor).  A level changes only bounds
        (a warm start, no coefficient), and the rows' duals are the weights y of :meth:`certify`.
        """
        if self._model is None:
            r, n, m = self.rows.g_rows.shape[0], self.n, self.n_dims
            a = np.zeros((r + m, n + 1 + m))
            a[:r, :n] = self.rows.g_rows
            a[np.arange(r), n + 1 + self.row_dim] = 1.0
            a[r:, n] = 1.0
            a[r + np.arange(m), n + 1 + np.arange(m)] = -1.0
            self._model = LinearModel(
                np.r_[np.zeros(n), -1.0, np.zeros(m)],
                a,
                np.full(r + m, -INF),
                np.r_[self.rows.g, np.zeros(m)],
                np.r_[self.rows.kmin, -INF, np.full(m, -INF)],
                np.r_[self.rows.kmax, INF, np.full(m, INF)],
            )
            self._model.keep_basis()
        return self._model

    def _floors(self, v: Array) -> Array:
        """Per row: the floor of its dimension (NaN: active)."""
        return v[self.row_dim]

    def rhs(self, v: Array) -> Array:
        """g_j on active rows, g_j − v_q(j) on fixed ones (+inf: a dimension left out)."""
        f = self._floors(v)
        return np.where(np.isnan(f), self.rows.g, self.rows.g - f)

    def _solve(
        self, hi: Array, v: Array, time_limit: float, spread: float = 0.0
    ) -> tuple[str, Array | None, Array | None]:
        """max t + spread·Σ_active u_q with rows ``hi`` (fixed rows' floors already in them, u_q ≥ 0 for
        fixed q): status, (k, t) and the rows' weights y ≥ 0."""
        lp, n, m = self._lp, self.n, self.n_dims
        active = np.isnan(v)
        cost = np.where(active, -spread, 0.0)
        if not np.array_equal(cost, self._cost):
            lp.set_costs(n + 1 + np.arange(m, dtype=np.int32), cost)
            self._cost = cost
        lp.set_row_bounds(
            np.full(hi.size + m, -INF), np.concatenate((np.where(np.isfinite(hi), hi, INF), np.where(active, 0.0, INF)))
        )
        lp.set_col_bounds(n + 1 + np.arange(m, dtype=np.int32), np.where(active, -INF, 0.0), np.full(m, INF))
        res = lp.solve(max(time_limit, 1e-3))
        y = None if res.row_dual is None else np.maximum(-res.row_dual[: hi.size], 0.0)
        x = None if res.x is None else res.x[: n + 1]
        return res.status if res.status != "error" else f"HiGHS: {res.detail}", x, y

    def level_of(self, k: Array, v: Array) -> float:
        """min over active rows of g_j − G_j k, or −inf if a fixed row is below its floor."""
        f = self._floors(v)
        m = self.rows.g - self.rows.g_rows @ k
        if (m - f < -TOL).any():  # fixed rows below their floor (an active row's NaN compares false)
            return -np.inf
        act = np.isnan(f)
        return float(m[act].min()) if act.any() else np.inf

    def round_best(self, x: Array, v: Array) -> tuple[Array, float]:
        """The best rounding of x (:func:`~setupfix.optimize.exact.leximin.pins.best_rounding`): (k, its level)."""
        return best_rounding(self.rows, x, self._floors(v), np.isnan(v[self.dims]), self.order, self.starts)

    def rounded(self, v: Array, tau: float) -> Array:
        """Rows rounded at τ (active) and at their floors (fixed): they hold every grid point of the level set."""
        f = self._floors(v)
        return rounded_rhs(self.rows.g, self.rows.d, self.rows.zero, np.where(np.isnan(f), tau, f))

    def step(self, v: Array, k: Array, eps: float, stage_end: float, tries: int = 1) -> LevelStep:
        """The level at k's own level t = min active margin, proved on the rounded rows; else a better point.

        Integer rows only.  b: the rows rounded at t (active) and at the floors (fixed); D: the
        active rows whose rounding at t + ε drops (by d_j); every grid point with all active margins
        ≥ t + ε meets the rows rounded at t + ε.  Proofs that none does (the level), each with row
        weights y that also pin rows (:func:`~setupfix.optimize.exact.leximin.pins.pinned_rows`):

        * small problems: a Farkas certificate of those rows by NNLS (no LP,
          :func:`~setupfix.optimize.exact.farkas.farkas_or_point`);
        * else the level LP (:meth:`_solve`) on b_j (D and fixed rows) and b_j + S (the other active
          rows), S = min_D d_j: it has t = S at every such grid point, so weights from its duals with
          C = max over the box of Σ y_j (rhs_j − G_j k) < S·Σ_active y_j prove it.

        Not proved: a point above t from an LP — the level LP on the unrounded rows first (its point
        spread by ``SPREAD``), then the one on the rounded rows — rounded (:meth:`round_best`) is the
        next point to try, at most ``tries`` times.
        """
        rows = self.rows
        act = np.isnan(self._floors(v))
        small = self.session.small
        calls, unrounded, ascents = 0, small, 0
        last: Array | None = None  # the last LP's point (k part)
        t = self.level_of(k, v)
        for _ in range(tries):
            if now() >= stage_end:
                return LevelStep(t, k, False, None, "time limit", calls)
            b = self.rounded(v, t)
            b_up = self.rounded(v, t + eps)
            drop = act & (b_up < b)
            if not drop.any():
                break
            fin = np.isfinite(b)
            if small:
                y, x_ld = farkas_or_point(rows, b_up, k)
                if y is not None:
                    cert = (y, np.where(fin, b, 0.0), np.zeros(b.size), True)
                    return LevelStep(
                        t, k, True, Certificates(rows.g_rows, rows.kmin, rows.kmax, (cert,)), None, calls, last
                    )
                if x_ld is not None and ascents < NNLS_ASCENTS:  # the rounded rows' least-distance point, rounded
                    ascents += 1
                    k_r, t_r = self.round_best(x_ld, v)
                    if t_r >= t + eps - 1e-9:
                        k, t = k_r, t_r
                        continue
            if unrounded:  # a point of the level LP (unrounded rows): usually at the level or next to it
                status, x, y = self._solve(self.rhs(v), v, stage_end - now(), SPREAD)
                unrounded = False
            else:
                gap = float(np.min(rows.d[drop]))
                rhs = np.where(act & ~drop, b + gap, b)
                status, x, y = self._solve(rhs, v, stage_end - now(), SPREAD)
                if not small and status == "optimal" and x is not None and y is not None:
                    y = np.where(np.isfinite(rhs), y, 0.0)
                    rhs0 = np.where(np.isfinite(rhs), rhs, 0.0)
                    w = y @ rows.g_rows
                    bound = float(y @ rhs0 + np.sum(np.maximum(-w * rows.kmin, -w * rows.kmax)))
                    total = float(y[act].sum())
                    if total > 0 and bound < gap * total - 1e-9 * (1.0 + abs(bound)):
                        cert = (y, rhs0, np.where(act & ~drop, gap, 0.0), True)
                        return LevelStep(
                            t,
                            k,
                            True,
                            Certificates(rows.g_rows, rows.kmin, rows.kmax, (cert,)),
                            None,
                            calls + 1,
                            x[:-1],
                        )
            calls += 1
            if status == "time_limit":
                return LevelStep(t, k, False, None, "time limit", calls)
            if status != "optimal" or x is None:
                break
            last = x[:-1]
            k_r, t_r = self.round_best(last, v)
            if t_r < t + eps - 1e-9:
                break
            k, t = k_r, t_r
        return LevelStep(t, k, False, None, None, calls)

    def value(self, v: Array, k_prev: Array, stage_end: float) -> LevelValue:
        """The proved level t_i (or the best point when stopped) — see the module text."""
        rows, s = self.rows, self.session.settings
        # with integer rows a step proves the level, so the LP may also spread the active margins (a
        # point for the next levels as well); its bound is then the weights' (weak duality), not its t
        spread = SPREAD if rows.all_integer else 0.0
        status, x, y = self._solve(self.rhs(v), v, stage_end - now(), spread)
        if status != "optimal" or x is None or y is None:
            reason = "time limit" if status == "time_limit" else status
            return LevelValue(self.level_of(k_prev, v), k_prev, np.inf, None, reason, (), 1)
        bound = level_bound(rows, y, self.rhs(v), np.isnan(v[self.row_dim])) if spread else -np.inf
        t_lp = max(float(x[-1]), bound)
        k_best, t_best = k_prev, self.level_of(k_prev, v)
        k_round, t_round = self.round_best(x[:-1], v)
        if t_round > t_best:
            k_best, t_best = k_round, t_round
        calls, path = 1, list[str]()
        if t_best >= t_lp - TOL:
            return LevelValue(t_best, k_best, t_lp, y, None, (), calls)
        eps = s.quantum / 2
        if rows.all_integer:  # ascent by steps: each LP either proves the level (and pins rows) or rises
            step = self.step(v, k_best, eps, stage_end, s.level_steps)
            calls += step.calls
            if step.stop is not None or step.proved:
                return LevelValue(step.t, step.k, t_lp, y, step.stop, (), calls, step.certificates)
            k_best, t_best = step.k, step.t
            if t_best >= t_lp - TOL:
                return LevelValue(t_best, k_best, t_lp, y, None, (), calls)
        # ascent: a grid point with every active margin ≥ t(best) + ε on the rounded rows (an LP, a feasibility
        # MILP), until none is left (proved) — the rounded LP point is usually at or next to the level.  A
        # zone's facet rows (irrational, more than two rows to a dimension) have no LP test: each step would
        # be a feasibility MILP rising by a little; the level MILP is one
        f = self._floors(v)
        for _ in range(0 if self.polygons and not rows.all_integer else s.level_steps):
            if now() >= stage_end:
                return LevelValue(t_best, k_best, t_lp, y, "time limit", tuple(path), calls)
            found = point_above(self.session, np.where(np.isnan(f), t_best + eps, f), stage_end)
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

    def _milp(
        self,
        v: Array,
        k_best: Array,
        t_best: float,
        upper: float,
        t_lp: float,
        y: Array | None,
        stage_end: float,
        path: list[str],
        calls: int,
    ) -> LevelValue:
        """max t, k integer, t ∈ [t(best point), upper], started from the best point."""
        rows = self.rows
        r, n = rows.g_rows.shape
        hi = self.rhs(v)
        a = np.hstack([rows.g_rows, np.isnan(self._floors(v))[:, None].astype(float)])
        model = LinearModel(
            np.r_[np.zeros(n), -1.0],
            a,
            np.full(r, -INF),
            np.where(np.isfinite(hi), hi, INF),
            np.r_[rows.kmin, t_best],
            np.r_[rows.kmax, upper],
            integer=np.r_[np.ones(n, bool), False],
        )
        res = model.solve(stage_end - now(), np.r_[k_best, t_best])
        calls += 1
        if res.x is not None and self.level_of(np.clip(np.rint(res.x[:-1]), rows.kmin, rows.kmax), v) < (
            -res.objective - 1e-6
        ):  # HiGHS 1.16 handed back the start with the optimum's objective
            res = model.solve(stage_end - now())
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
        found = point_above(self.session, f, stage_end)
        return None if found is None else found is not False

    def alone_at(self, v: Array, dims: tuple[int, ...], t: float, eps: float, stage_end: float) -> Array | bool | None:
        """A grid point with every active dimension but ``dims`` at t + ε or more (those ≥ t, fixed ≥
        floors); False: proved none; None: stopped."""
        f = self._floors(v).copy()
        f[np.isnan(f)] = t + eps
        f[np.isin(self.row_dim, dims)] = t
        return point_above(self.session, f, stage_end)

    # -- certificates of saturation ---------------------------------------------------------------
    def certify(self, level: LevelValue, v: Array) -> Certificates:
        """The level LP's weights (rhs g on active rows, g − v on fixed rows; active floor t)."""
        certs: tuple[tuple[Array, Array, Array, bool], ...] = ()
        if level.y is not None:
            rhs = self.rhs(v)
            y = np.where(np.isfinite(rhs), level.y, 0.0)
            active = np.isnan(self._floors(v))
            if float(y[active].sum()) > 0:
                certs = ((y, np.where(np.isfinite(rhs), rhs, 0.0), np.where(active, level.t, 0.0), False),)
        return Certificates(self.rows.g_rows, self.rows.kmin, self.rows.kmax, certs)

    def certify_rounded(self, level: LevelValue, v: Array, stage_end: float) -> Certificates:
        """max s s.t. G_j k + s ≤ b_j (active), G_j k ≤ b_j (fixed), b rounded at t: its weights pin rows."""
        b = self.rounded(v, level.t)
        status, _, y = self._solve(b, v, stage_end - now())
        certs: tuple[tuple[Array, Array, Array, bool], ...] = ()
        if status == "optimal" and y is not None:
            y = np.where(np.isfinite(b), y, 0.0)
            certs = ((y, np.where(np.isfinite(b), b, 0.0), np.zeros(b.size), True),)
        return Certificates(self.rows.g_rows, self.rows.kmin, self.rows.kmax, certs)
