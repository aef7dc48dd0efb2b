"""The least norm Σ c_i k_i² (eq. 9) among grid points, by listing the integer points of an ellipsoid.

Grid units as in :mod:`setupfix.optimize.exact.grid`: corrections k (integer steps), margin
rows ``m_j(k) = g_j − G_j·k``, error budget ``t(k) = min_j m_j(k)``.

Among grid points with t(k) ≥ t*: :func:`lagrangian_ball` + :func:`enumerate_ball` — for any multipliers λ ≥ 0
of the constraints G k ≤ b, kmin ≤ k ≤ kmax, every feasible k satisfies
f(k) = Σ c_i k_i² ≥ L(k, λ) = Σ c_i (k_i − κ_i)² + q (separable in k).  So
every feasible k with f(k) ≤ F (F: the best feasible point known) lies in the
ellipsoid Σ c_i (k_i − κ_i)² ≤ F − q, whose integer points are listed
exhaustively (Fincke–Pohst order: coordinate by coordinate with the radius
left).  The least f among the feasible ones is the grid least norm — a proof
by exhaustion, exact whatever λ is (the duals of the continuous least-norm QP
make the ellipsoid small).  When the list would exceed ``limit`` points the
caller falls back to the chord MILP.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.grid import TOL, grid_margins

__all__ = ["WORK_LIMIT", "ellipsoid_search", "enumerate_ball", "lagrangian_ball"]

Array = npt.NDArray[np.float64]

#: Array elements one enumeration may touch in all (some 20 ms of numpy work) before it gives up.
WORK_LIMIT = 4_000_000


def lagrangian_ball(
    g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array, lam_rows: Array, lam_lo: Array, lam_hi: Array
) -> tuple[Array, float]:
    """Centre κ and value q of the Lagrangian bound f(k) ≥ Σ c_i (k_i − κ_i)² + q.

    Valid for every k with G k ≤ b and kmin ≤ k ≤ kmax, for any λ ≥ 0; the
    multipliers are scaled by the s ≥ 0 that maximises q (a concave quadratic in s).

    Parameters
    ----------
    g_rows : ndarray of shape (r, n)
    b : ndarray of shape (r,)
    kmin, kmax, cost : ndarray of shape (n,)
    lam_rows : ndarray of shape (r,); lam_lo, lam_hi : ndarray of shape (n,)

    Returns
    -------
    centre : ndarray of shape (n,)
    q : float
    """
    lam_rows, lam_lo, lam_hi = (np.maximum(np.asarray(v, dtype=float), 0.0) for v in (lam_rows, lam_lo, lam_hi))
    w = lam_rows @ g_rows - lam_lo + lam_hi
    c0 = float(-lam_rows @ b + lam_lo @ kmin - lam_hi @ kmax)
    a = float(np.sum(w * w / (4 * cost)))
    if not (a > 0 and c0 > 0 and np.isfinite(a) and np.isfinite(c0)):
        return np.zeros_like(cost), 0.0
    s = c0 / (2 * a)
    return -s * w / (2 * cost), c0 * c0 / (4 * a)


def enumerate_ball(
    centre: Array,
    cost: Array,
    radius2: float,
    kmin: Array,
    kmax: Array,
    limit: int,
    rows: Array | None = None,
    rhs: Array | None = None,
    fmax: float = np.inf,
    work_limit: int = WORK_LIMIT,
    multipliers: tuple[Array, Array, Array] | None = None,
) -> npt.NDArray[np.float64] | None:
    """Every integer k in the box with Σ c_i (k_i − centre_i)² ≤ radius2 [rows·k ≤ rhs] [Σ c_i k_i² ≤ fmax].

    Coordinates are fixed one at a time, breadth first (all partial points of one depth
    as one array).  A partial point is dropped as soon as no completion can meet the
    conditions; with E_rest the radius² left for the coordinates not yet fixed:

    * the radius: the next coordinate's range is |k_i − centre_i| ≤ √(E_rest / c_i);
    * a row a·k ≤ rhs (``rows``/``rhs``): the rest's part a_r·k_r is at least the larger of
      its minimum over the box and a_r·centre_r − √E_rest·‖a_r/√c_r‖ (Cauchy–Schwarz on the
      rest's ellipsoid);
    * the norm (``fmax``): Σ_r c k_r² is at least the larger of Σ_r min over the box of c k_r²
      and (‖centre_r‖_c − √E_rest)² (triangle inequality in the c-norm), and, given
      ``multipliers`` (λ ≥ 0 of ``rows`` and of the box bounds kmin, kmax), the Lagrangian dual
      bound of the rest's continuous problem "min Σ_r c k_r², rows with the fixed part moved to
      the right, box": max over s ≥ 0 of −s²·Σ_r w_r²/(4 c_r) − s·B, w = λᵀ[rows; I; −I] on
      the rest, B = λ·(slack left to the rest) — B²/(4·Σ w²/4c) when B < 0 (weak duality, any λ).

    Each bound holds for every completion, so nothing with the stated properties is ever
    dropped, and the last coordinate checks them exactly: the list is exactly those points.
    With a finite ``fmax`` coordinates are fixed largest |√c·centre| first (the norm bound
    bites early); otherwise fewest candidates first.

    Returns
    -------
    ndarray of shape (N, n), or None if more than ``limit`` partial points would be
    listed at some coordinate, or more than ``work_limit`` array elements touched in all
    (the caller then needs another proof).
    """
    n = centre.size
    half = np.sqrt(max(radius2, 0.0) / cost)
    lo_all = np.maximum(np.ceil(centre - half - 1e-12), kmin)
    hi_all = np.minimum(np.floor(centre + half + 1e-12), kmax)
    if np.any(lo_all > hi_all):
        return np.zeros((0, n))
    counts_all = hi_all - lo_all + 1
    f_slack = fmax + 1e-9 * max(1.0, abs(fmax)) if np.isfinite(fmax) else np.inf
    if np.prod(counts_all) <= 4096:  # a small box around the centre: list it whole, keep the ellipsoid
        grid = np.indices(tuple(int(c) for c in counts_all)).reshape(n, -1).T + lo_all
        keep = np.sum(cost * (grid - centre) ** 2, axis=1) <= radius2
        if np.isfinite(f_slack):
            keep &= np.sum(cost * grid**2, axis=1) <= f_slack
        if rows is not None and rhs is not None and rows.shape[0]:
            keep &= np.all(grid @ rows.T <= rhs + 1e-7, axis=1)
        kept: Array = grid[keep]
        return kept
    if np.isfinite(f_slack):
        order = np.argsort(-np.sqrt(cost) * np.abs(centre), kind="stable")
    else:
        order = np.argsort(counts_all, kind="stable")  # fewest candidates first keeps the lists short
    c, ce, lo_o, hi_o = cost[order], centre[order], lo_all[order], hi_all[order]

    def after(x: Array) -> Array:  # after(x)[..., p] = Σ_{q > p} x[..., q]
        s = np.cumsum(x[..., ::-1], axis=-1)[..., ::-1]
        return np.concatenate([s[..., 1:], np.zeros((*s.shape[:-1], 1))], axis=-1)

    rest_f = after(c * np.where((lo_o <= 0) & (hi_o >= 0), 0.0, np.minimum(lo_o**2, hi_o**2)))
    rest_norm = np.sqrt(after(c * ce**2))
    dual = multipliers is not None and rows is not None and rhs is not None and np.isfinite(f_slack)
    a = np.zeros((0, n))
    rhs_live = np.zeros(0)
    if rows is not None and rhs is not None:
        a = rows[:, order]
        if dual:
            assert multipliers is not None
            lam = np.maximum(multipliers[0], 0.0)
            lam_lo, lam_hi = (np.maximum(v, 0.0)[order] for v in multipliers[1:])
            lam_a = lam @ a  # (n,): λ·row coefficient of each coordinate
            w = lam_a + lam_hi - lam_lo
            rest_quad = after(w * w / (4 * c))
            rest_slack = float(lam @ rhs) + after(lam_hi * kmax[order] - lam_lo * kmin[order])
        # rows no point of the ellipsoid can violate are left out
        top = np.minimum(
            np.sum(np.maximum(a * lo_o, a * hi_o), axis=1),
            a @ ce + np.sqrt(max(radius2, 0.0)) * np.sqrt(np.sum(a * a / c, axis=1)),
        )
        live = top > rhs + 1e-7
        a, rhs_live = a[live], rhs[live]
        limit = min(limit, max(1, (1 << 24) // max(a.shape[0], 1)))
    pruned = a.shape[0] > 0
    rest_box = after(np.minimum(a * lo_o, a * hi_o))  # (r, n): least a_r·k_r over the box
    rest_centre = after(a * ce)
    rest_scale = np.sqrt(after(a * a / c))
    partial = np.zeros((1, a.shape[0]))
    acc = np.zeros(1)
    f_acc = np.zeros(1)
    lam_acc = np.zeros(1)
    values: list[Array] = []  # per depth: the value of each partial point and the index of its parent
    parents: list[npt.NDArray[np.intp]] = []
    work = 0
    width = 2 + a.shape[0]
    for p in range(n):
        rem = np.maximum(radius2 - acc, 0.0)
        h = np.sqrt(rem / c[p])
        lo = np.maximum(np.ceil(ce[p] - h - 1e-12), lo_o[p])
        hi = np.minimum(np.floor(ce[p] + h + 1e-12), hi_o[p])
        counts = np.maximum(hi - lo + 1, 0).astype(np.int64)
        total = int(counts.sum())
        work += total * width
        if total > limit or work > work_limit:
            return None
        if total == 0:
            return np.zeros((0, n))
        rep = np.repeat(np.arange(counts.size), counts)
        vals = lo[rep] + (np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts))
        acc = acc[rep] + c[p] * (vals - ce[p]) ** 2
        f_acc = f_acc[rep] + c[p] * vals**2
        root = np.sqrt(np.maximum(radius2 - acc, 0.0))
        low_f = np.maximum(rest_f[p], np.maximum(rest_norm[p] - root, 0.0) ** 2)
        if dual:
            lam_acc = lam_acc[rep] + vals * lam_a[p]
            slack = rest_slack[p] - lam_acc
            if rest_quad[p] > 1e-12:
                low_f = np.maximum(low_f, np.where(slack < 0, slack * slack / (4 * rest_quad[p]), 0.0))
            else:  # nothing left to move: a negative weighted slack is a violated row
                low_f = np.where(slack < -1e-7 * max(1.0, float(np.max(np.abs(lam), initial=0.0))), np.inf, low_f)
        keep = np.flatnonzero(f_acc + low_f <= f_slack)
        rep, vals, acc, f_acc, root = rep[keep], vals[keep], acc[keep], f_acc[keep], root[keep]
        if dual:
            lam_acc = lam_acc[keep]
        if pruned:
            partial = partial[rep] + vals[:, None] * a[:, p][None, :]
            low = np.maximum(rest_box[:, p], rest_centre[:, p] - root[:, None] * rest_scale[:, p])
            ok = np.flatnonzero(np.all(partial + low <= rhs_live + 1e-7, axis=1))
            rep, vals, acc, f_acc, partial = rep[ok], vals[ok], acc[ok], f_acc[ok], partial[ok]
            if dual:
                lam_acc = lam_acc[ok]
        if vals.size == 0:
            return np.zeros((0, n))
        values.append(vals)
        parents.append(rep)
    pts = np.empty((values[-1].size, n))
    idx = np.arange(values[-1].size)
    for p in range(n - 1, -1, -1):  # back along the parents
        pts[:, order[p]] = values[p][idx]
        idx = parents[p][idx]
    return pts


def ellipsoid_search(
    g_rows: Array,
    g: Array,
    level: float,
    centre: Array,
    q: float,
    cost: Array,
    kmin: Array,
    kmax: Array,
    f_known: float,
    limit: int,
    b: Array | None = None,
    work_limit: int = WORK_LIMIT,
    multipliers: tuple[Array, Array, Array] | None = None,
) -> tuple[Array | None, bool, int]:
    """Least Σ c k² among grid points with t(k) ≥ level, by growing ellipsoids around ``centre``.

    Every feasible k satisfies Σ c (k − centre)² ≤ f(k) − q (:func:`lagrangian_ball`).
    Radii² 1, 4, 16, … up to f − q (f: the least norm of a feasible point known so far,
    ``f_known`` at first, or inf), or up to the radius² that holds the whole box, are listed in turn, only
    points of norm ≤ f (pruned by
    the rows G k ≤ b, which every feasible point meets, when ``b`` is given); as soon as
    the best feasible point found, of norm f_b, has f_b − q ≤ the radius² listed, nothing
    outside can beat it and it is the least (ties: the lexicographically smallest k).
    ``multipliers`` (λ of the rows G k ≤ b, of k ≥ kmin and of k ≤ kmax; any λ ≥ 0) sharpen
    the pruning by the norm (:func:`enumerate_ball`).

    Returns
    -------
    best : ndarray of shape (n,) or None
        The least feasible point found with f ≤ f_known, the lexicographically smallest of
        equal norms (None: none found; a known point of norm ``f_known`` that is feasible is
        in the list, so ``best`` is then at most as large and lexicographically no larger).
    proved : bool
        True when ``best`` (or, if None, the known point) is proven least.
    listed : int
        Grid points listed in the last ellipsoid.
    """

    def room(f: float) -> float:
        return f - q + 1e-9 * max(1.0, abs(f)) if np.isfinite(f) else np.inf

    # an ellipsoid holding the whole box lists every grid point: no larger radius is needed
    whole = float(np.sum(cost * np.maximum((kmin - centre) ** 2, (kmax - centre) ** 2)))
    cap = min(room(f_known), whole)
    f_cut = f_known
    radius2 = min(1.0, cap)
    listed = 0
    best = None
    fin = None if b is None else np.isfinite(b)
    while True:
        if b is None or fin is None:
            points = enumerate_ball(centre, cost, radius2, kmin, kmax, limit, fmax=f_cut, work_limit=work_limit)
        else:
            lam = None if multipliers is None else (multipliers[0][fin], multipliers[1], multipliers[2])
            points = enumerate_ball(
                centre,
                cost,
                radius2,
                kmin,
                kmax,
                limit,
                g_rows[fin],
                b[fin],
                fmax=f_cut,
                work_limit=work_limit,
                multipliers=lam,
            )
        if points is None:
            return best, False, listed
        listed = points.shape[0]
        if listed:
            ok = points[grid_margins(g_rows, g, points) >= level - TOL]
            if ok.shape[0]:
                f = np.sum(cost * ok**2, axis=1)
                order = np.lexsort((*ok.T[::-1], f))  # least norm, ties by the smallest k
                # ties with the known point count: the list holds it, so the pick is the smallest of them
                if f[order[0]] <= f_known + 1e-12 * max(1.0, abs(f_known)):
                    best = ok[order[0]]
                    f_cut = float(f[order[0]])
                    cap = min(cap, room(f_cut))
                    if f_cut - q <= radius2:
                        return best, True, listed
        if radius2 >= cap:
            return best, True, listed
        radius2 = min(radius2 * 4, cap)
