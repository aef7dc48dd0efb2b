"""Proofs on the register grid that spare the exact optimiser a MILP.

Everything is in grid units: corrections k (integer steps), margin rows
``m_j(k) = g_j − G_j·k`` and the error budget ``t(k) = min_j m_j(k)`` (see
:func:`setupfix.optimize._exact.margin_rows`).  Each function returns a bound or a
point together with what proves it; none of them guesses.

Bounds on the grid optimum t* = max_k t(k)
    * :func:`dual_bound` — weak LP duality: for any y ≥ 0 with Σy = 1,
      t(k) ≤ Σ_j y_j m_j(k) ≤ y·g + max_{k in box} (−Gᵀy)·k.  Computed from the
      solver's duals with numpy, so it holds whatever the solver's tolerances.
    * :func:`pair_bound` — rows with opposite integer coefficients, G_i = −G_j = a
      (two dimensions that every register moves alike, or the two limits of one
      dimension): m_i + m_j = g_i + g_j for every k, and a·k is a multiple of
      d = gcd(a) in [min a·k, max a·k] over the box, so
      min(m_i, m_j) ≤ max_{z ∈ dℤ} min(g_i − z, g_j + z), which is below the LP
      bound when the even split (g_i − g_j)/2 is off the lattice.  This is the
      "rounded bound" of the paper's example (P1 D6 and P1 D7).

Rounded rows (Chvátal–Gomory rounding of single rows)
    A row with integer coefficients a and gcd d takes only multiples of d on the
    grid, so ``a·k ≤ b`` implies ``a·k ≤ d·⌊b/d⌋`` (:func:`rounded_rhs`).  The
    system rounded at a level τ contains every grid point with t(k) ≥ τ, and
    stays the same for every τ down to :func:`next_level`; so when its
    continuous relaxation is empty, no grid point has t(k) above that next level
    (a tighter bound, one QP/LP per level), and when its least-norm point is on
    the grid, that point is the grid least norm at τ.

Least norm among grid points with t(k) ≥ t*
    :func:`lagrangian_ball` + :func:`enumerate_ball` — for any multipliers λ ≥ 0
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

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array

__all__ = ["TOL", "grid_margins", "dual_bound", "pair_bound", "pair_structure", "PairStructure", "row_gcd", "rounded_rhs", "next_level",
           "least_distance", "lagrangian_ball", "enumerate_ball", "ellipsoid_search"]

Array = npt.NDArray[np.float64]

#: Tolerance of every comparison of margins [grid steps].  Deviations are quantised to
#: 1/1000 step before solving, so distinct margins from one dimension differ by far more.
TOL = 1e-9

#: Array elements one enumeration may touch in all (some 20 ms of numpy work) before it gives up.
WORK_LIMIT = 4_000_000
#: Elements per block when margins of many points are evaluated at once.
_BLOCK = 1 << 22


def grid_margins(g_rows: Array, g: Array, k: Array) -> Array:
    """Smallest margin [steps] of each point.

    k : ndarray of shape (n,) or (N, n) → float or ndarray of shape (N,)
    """
    k = np.asarray(k, dtype=float)
    if g.size == 0:
        return np.full(k.shape[:-1], np.inf) if k.ndim > 1 else np.array(np.inf)
    if k.ndim == 1:
        return np.array(np.min(g - g_rows @ k))
    out = np.empty(k.shape[0])
    step = max(1, _BLOCK // max(g.size, 1))
    for s in range(0, k.shape[0], step):
        out[s:s + step] = np.min(g[None, :] - k[s:s + step] @ g_rows.T, axis=1)
    return out


def dual_bound(g_rows: Array, g: Array, y: Array, kmin: Array, kmax: Array) -> float:
    """Upper bound on max_k t(k) over the box from row weights y ≥ 0 (weak duality).

    Parameters
    ----------
    g_rows : ndarray of shape (r, n)
    g : ndarray of shape (r,)
    y : ndarray of shape (r,)
        Any non-negative weights (normalised here to sum 1); the LP's duals give the
        LP optimum.
    kmin, kmax : ndarray of shape (n,)

    Returns
    -------
    float
        inf when y is zero.
    """
    y = np.maximum(np.asarray(y, dtype=float), 0.0)
    total = y.sum()
    if not np.isfinite(total) or total <= 0:
        return np.inf
    y = y / total
    w = y @ g_rows
    return float(y @ g + np.sum(np.maximum(-w * kmin, -w * kmax)))


@dataclass(frozen=True)
class PairStructure:
    """Groups of identical rows and the pairs of groups with opposite coefficients (per G and box)."""

    inverse: npt.NDArray[np.intp]  # (r,) group of each row
    n_groups: int
    ia: npt.NDArray[np.intp]  # (p,) first group of each pair
    ib: npt.NDArray[np.intp]  # (p,) its opposite
    d: Array  # (p,) gcd of the coefficients
    zlo: Array  # (p,) smallest a·k over the box
    zhi: Array  # (p,) largest a·k over the box


def pair_structure(g_rows: Array, kmin: Array, kmax: Array) -> PairStructure | None:
    """The pairs :func:`pair_bound` uses; None when there are none (or non-integer rows)."""
    if g_rows.shape[0] < 2 or not np.all(g_rows == np.rint(g_rows)):
        return None
    # Rows are grouped by a random integer projection (equal rows, equal keys; a collision of
    # different rows is checked away below), which is far cheaper than sorting whole rows.
    weights = np.random.default_rng(0).integers(1, 2**20, g_rows.shape[1]).astype(float)
    keys = g_rows @ weights
    uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    rows = g_rows[first] + 0.0
    if not np.array_equal(rows[inverse.ravel()], g_rows + 0.0):
        return None  # a collision: no pair bound (never wrong, only weaker)
    where = {float(k): i for i, k in enumerate(uniq)}
    negated = [where.get(float(-k), -1) for k in uniq]
    pairs = [(i, j) for i, j in enumerate(negated)
             if i < j and np.any(rows[i]) and np.array_equal(rows[j], -rows[i] + 0.0)]
    if not pairs:
        return None
    ia, ib = (np.array(v, dtype=np.intp) for v in zip(*pairs))
    a = rows[ia]
    d = np.gcd.reduce(np.abs(a).astype(np.int64), axis=1).astype(float)
    zlo = np.sum(np.minimum(a * kmin, a * kmax), axis=1)
    zhi = np.sum(np.maximum(a * kmin, a * kmax), axis=1)
    return PairStructure(inverse.ravel(), rows.shape[0], ia, ib, d, zlo, zhi)


def pair_bound(g_rows: Array, g: Array, kmin: Array, kmax: Array, structure: PairStructure | None = None) -> float:
    """Upper bound on max_k t(k) from pairs of rows with opposite integer coefficients.

    ``structure`` (from :func:`pair_structure`) may be passed when G and the box are
    unchanged.  Returns inf when no such pair exists or the coefficients are not integers.
    """
    ps = pair_structure(g_rows, kmin, kmax) if structure is None else structure
    if ps is None:
        return np.inf
    gmin = np.full(ps.n_groups, np.inf)
    np.minimum.at(gmin, ps.inverse, g)
    ga, gb = gmin[ps.ia], gmin[ps.ib]
    z0 = (ga - gb) / 2
    best = np.full(ga.size, -np.inf)
    for z in (np.floor(z0 / ps.d) * ps.d, np.ceil(z0 / ps.d) * ps.d):
        z = np.clip(z, ps.zlo, ps.zhi)  # zlo, zhi are themselves multiples of d
        best = np.maximum(best, np.minimum(ga - z, gb + z))
    return float(best.min())


def row_gcd(g_rows: Array) -> npt.NDArray[np.float64]:
    """Per row: gcd of its coefficients if they are all integers and not all zero, else 0.

    Returns
    -------
    ndarray of shape (r,)
    """
    integer = np.all(g_rows == np.rint(g_rows), axis=1)
    d = np.zeros(g_rows.shape[0])
    if np.any(integer):
        d[integer] = np.gcd.reduce(np.abs(np.rint(g_rows[integer])).astype(np.int64), axis=1)
    return d


def rounded_rhs(g: Array, d: Array, zero: npt.NDArray[np.bool_], tau: float) -> Array:
    """Right-hand sides b with {k : G k ≤ b} ⊇ {grid k : t(k) ≥ τ}.

    Integer rows (d > 0): d·⌊(g − τ)/d⌋ (with 1e-7 slack: rounding up a value a hair
    below an integer only relaxes); zero rows (``zero``): +inf when g ≥ τ, else −1
    (0 ≤ −1: empty); other rows: g − τ + TOL.
    """
    b = g - tau + TOL
    m = d > 0
    b[m] = d[m] * np.floor((g[m] - tau) / d[m] + 1e-7)
    b[zero] = np.where(g[zero] >= tau - TOL, np.inf, -1.0)
    return b


def next_level(g: Array, d: Array, b: Array) -> float:
    """Largest τ' such that the system rounded at any level in (τ', τ] is ``b``.

    Only for systems whose rows are all integer (d > 0) or zero: then an empty
    rounded system at τ proves t(k) ≤ τ' for every grid point with t(k) ≤ τ.
    """
    m = d > 0
    return float(np.max(g[m] - b[m] - d[m])) if np.any(m) else -np.inf


def least_distance(g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array
                   ) -> tuple[str, tuple[Array, Array, Array, Array] | None]:
    """Least Σ c k² subject to G k ≤ b and the box, by NNLS (Lawson & Hanson 1974, ch. 23).

    With k' = √c·k and the constraints written M k ≥ m, the least-distance problem
    min ‖k'‖ s.t. M' k' ≥ m is solved through u = NNLS(E, e_{n+1}), E = [M'ᵀ; mᵀ]:
    the residual r = E u − e_{n+1} gives k' = −r[:n]/r[n], and u are (up to scale)
    the multipliers of the constraints.  r = 0 means infeasible, and u is then a
    Farkas certificate, checked here: Mᵀu = ε, mᵀu = s > 0 and ‖ε‖₁·max|k| < s over
    the box proves that no k satisfies the constraints.

    Rows with b = +inf are left out.  Returns ``("optimal", (k, λ_rows, λ_lower,
    λ_upper))``, ``("infeasible", None)`` with a checked certificate, or
    ``("unknown", None)``.
    """
    from scipy.optimize import nnls

    n = kmin.size
    keep = np.isfinite(b)
    rows = g_rows[keep]
    m_mat = np.vstack([-rows, np.eye(n), -np.eye(n)])
    m_vec = np.r_[-b[keep], kmin, -kmax]
    scale = 1.0 / np.sqrt(cost)
    e = np.vstack([(m_mat * scale).T, m_vec[None, :]])
    f = np.zeros(n + 1)
    f[-1] = 1.0
    try:
        u, _ = nnls(e, f, maxiter=50 * e.shape[1])
    except RuntimeError:  # iteration limit
        return "unknown", None
    r = e @ u - f
    if abs(r[-1]) > 1e-9:
        k = -r[:n] / r[-1] * scale
        lam = np.zeros(b.size)
        lam[keep] = u[: rows.shape[0]]
        return "optimal", (k, lam, u[rows.shape[0]:rows.shape[0] + n], u[rows.shape[0] + n:])
    eps = m_mat.T @ u
    s = float(m_vec @ u)
    if s > 0 and float(np.sum(np.abs(eps))) * float(np.max(np.abs(np.r_[kmin, kmax]), initial=0.0)) < s:
        return "infeasible", None
    return "unknown", None


def lagrangian_ball(g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array, lam_rows: Array,
                    lam_lo: Array, lam_hi: Array) -> tuple[Array, float]:
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


def enumerate_ball(centre: Array, cost: Array, radius2: float, kmin: Array, kmax: Array, limit: int,
                   rows: Array | None = None, rhs: Array | None = None) -> npt.NDArray[np.float64] | None:
    """Every integer k in the box with Σ c_i (k_i − centre_i)² ≤ radius2 [and rows·k ≤ rhs].

    Coordinates are fixed one at a time (fewest candidates first); a partial point is
    dropped as soon as the radius is spent or, when ``rows``/``rhs`` are given, some
    row cannot be met whatever the remaining coordinates take in their ranges.

    Returns
    -------
    ndarray of shape (N, n), or None if more than ``limit`` partial points would be
    listed at some coordinate (the caller then needs another proof).
    """
    n = centre.size
    half = np.sqrt(max(radius2, 0.0) / cost)
    lo_all = np.maximum(np.ceil(centre - half - 1e-12), kmin)
    hi_all = np.minimum(np.floor(centre + half + 1e-12), kmax)
    if np.any(lo_all > hi_all):
        return np.zeros((0, n))
    counts_all = hi_all - lo_all + 1
    if np.prod(counts_all) <= 4096:  # a small box around the centre: list it whole, keep the ellipsoid
        grid = np.indices(tuple(int(c) for c in counts_all)).reshape(n, -1).T + lo_all
        return grid[np.sum(cost * (grid - centre) ** 2, axis=1) <= radius2]
    order = np.argsort(counts_all, kind="stable")  # fewest candidates first keeps the lists short
    if rows is not None and rhs is not None:
        a = rows[:, order]
        cmin = np.minimum(a * lo_all[order], a * hi_all[order])  # (r, n)
        rest = np.cumsum(cmin[:, ::-1], axis=1)[:, ::-1]  # rest[:, p] = Σ_{q ≥ p} cmin[:, q]
        rest = np.hstack([rest[:, 1:], np.zeros((a.shape[0], 1))])  # Σ over q > p
        limit = min(limit, max(1, (1 << 24) // max(a.shape[0], 1)))
        partial = np.zeros((1, a.shape[0]))
    pts = np.zeros((1, 0))
    acc = np.zeros(1)
    work = 0
    width = 1 + (0 if rows is None else rows.shape[0])
    for p, i in enumerate(order):
        rem = np.maximum(radius2 - acc, 0.0)
        h = np.sqrt(rem / cost[i])
        lo = np.maximum(np.ceil(centre[i] - h - 1e-12), kmin[i])
        hi = np.minimum(np.floor(centre[i] + h + 1e-12), kmax[i])
        counts = np.maximum(hi - lo + 1, 0).astype(np.int64)
        total = int(counts.sum())
        work += total * (width + p)
        if total > limit or work > WORK_LIMIT:
            return None
        if total == 0:
            return np.zeros((0, n))
        rep = np.repeat(np.arange(counts.size), counts)
        offset = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        vals = lo[rep] + offset
        pts = np.column_stack([pts[rep], vals])
        acc = acc[rep] + cost[i] * (vals - centre[i]) ** 2
        if rows is not None and rhs is not None:
            partial = partial[rep] + vals[:, None] * a[:, p][None, :]
            keep = np.all(partial + rest[:, p] <= rhs + 1e-7, axis=1)
            pts, acc, partial = pts[keep], acc[keep], partial[keep]
            if pts.shape[0] == 0:
                return np.zeros((0, n))
    out = np.empty_like(pts)
    out[:, order] = pts
    return out


def ellipsoid_search(g_rows: Array, g: Array, level: float, centre: Array, q: float, cost: Array, kmin: Array,
                     kmax: Array, f_known: float, limit: int, b: Array | None = None) -> tuple[Array | None, bool, int]:
    """Least Σ c k² among grid points with t(k) ≥ level, by growing ellipsoids around ``centre``.

    Every feasible k satisfies Σ c (k − centre)² ≤ f(k) − q (:func:`lagrangian_ball`).
    Radii² 1, 4, 16, … up to f_known − q (f_known: the norm of a feasible point
    already known, or inf) are listed in turn (pruned by the rows G k ≤ b, which
    every feasible point meets, when ``b`` is given); as soon as the best feasible point
    found, of norm f_b, has f_b − q ≤ the radius² listed, nothing outside can beat
    it and it is the least.

    Returns
    -------
    best : ndarray of shape (n,) or None
        The least feasible point found with f < f_known (None: none better).
    proved : bool
        True when ``best`` (or, if None, the known point) is proven least.
    listed : int
        Grid points listed in the last ellipsoid.
    """
    cap = f_known - q + 1e-9 * max(1.0, abs(f_known)) if np.isfinite(f_known) else np.inf
    radius2 = min(1.0, cap)
    listed = 0
    while True:
        if b is None:
            points = enumerate_ball(centre, cost, radius2, kmin, kmax, limit)
        else:
            fin = np.isfinite(b)
            points = enumerate_ball(centre, cost, radius2, kmin, kmax, limit, g_rows[fin], b[fin])
        if points is None:
            return None, False, listed
        listed = points.shape[0]
        best = None
        if listed:
            ok = points[grid_margins(g_rows, g, points) >= level - TOL]
            if ok.shape[0]:
                f = np.sum(cost * ok**2, axis=1)
                order = np.lexsort((*ok.T[::-1], f))  # least norm, ties by the smallest k
                if f[order[0]] < f_known:
                    best = ok[order[0]]
                    if f[order[0]] - q <= radius2:
                        return best, True, listed
        if radius2 >= cap:
            return best, True, listed
        radius2 = min(radius2 * 4, cap)



def chord_rows(pairs: list[tuple[int, int]], n: int, width: int) -> tuple[csr_array, npt.NDArray[np.float64]]:
    """Chord cuts of k² on the integers: ``s_i ≥ (2j+1)·|k_i| − j(j+1)`` for each (i, j).

    On integers k² is exactly the upper envelope of these chords, so with enough of them
    Σ s_i is Σ k_i² (the least-norm stage, eq. 9, as an exact MILP).

    Parameters
    ----------
    pairs : list of (i, j)
        Register index i and chord j ≥ 0; each pair gives the two rows for +k_i and −k_i.
    n : int
        Number of registers: columns 0…n−1 are k, n…2n−1 are s.
    width : int
        Total number of columns of the model (≥ 2n; the rest are zero here).

    Returns
    -------
    A : csr_array of shape (2·len(pairs), width)
        Rows ``±(2j+1)·k_i − s_i``.
    rhs : ndarray of shape (2·len(pairs),)
        Upper bounds ``j(j+1)``.
    """
    i = np.array([p[0] for p in pairs for _ in (0, 1)])
    j = np.array([p[1] for p in pairs for _ in (0, 1)], dtype=float)
    sign = np.tile([1.0, -1.0], len(pairs))
    m = len(i)
    rows = np.r_[np.arange(m), np.arange(m)]
    cols = np.r_[i, n + i]
    vals = np.r_[sign * (2 * j + 1), -np.ones(m)]
    return csr_array(coo_array((vals, (rows, cols)), shape=(m, width))), j * (j + 1)
