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

__all__ = ["TOL", "grid_margins", "dual_bound", "pair_bound", "pair_structure", "PairStructure", "row_gcd", "rounded_rhs", "next_level",
           "least_distance", "nnls_least_distance", "least_distance_system", "lagrangian_ball", "enumerate_ball",
           "ellipsoid_search"]

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


def least_distance(g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array,
                   system: tuple[Array, Array] | None = None
                   ) -> tuple[str, tuple[Array, Array, Array, Array] | None]:
    """Least Σ c k² subject to G k ≤ b and the box, by NNLS (Lawson & Hanson 1974, ch. 23).

    With k' = √c·k and the constraints written M k ≥ m, the least-distance problem
    min ‖k'‖ s.t. M' k' ≥ m is solved through u = NNLS(E, e_{n+1}), E = [M'ᵀ; mᵀ]:
    the residual r = E u − e_{n+1} gives k' = −r[:n]/r[n], and u are (up to scale)
    the multipliers of the constraints.  r = 0 means infeasible, and u is then a
    Farkas certificate, checked here: Mᵀu = ε, mᵀu = s > 0 and ‖ε‖₁·max|k| < s over
    the box proves that no k satisfies the constraints.

    Rows with b = +inf are left out.  ``system``: the part that does not depend on b
    (:func:`least_distance_system` of the rows kept), for a caller that solves many b.
    Returns ``("optimal", (k, λ_rows, λ_lower, λ_upper))``, ``("infeasible", None)`` with a
    checked certificate, or ``("unknown", None)``.
    """
    n = kmin.size
    keep = np.isfinite(b)
    n_rows = int(keep.sum())
    m_mat, e = least_distance_system(g_rows[keep], cost) if system is None else system
    e = e.copy()
    e[-1, :n_rows] = -b[keep]
    e[-1, n_rows:n_rows + n] = kmin
    e[-1, n_rows + n:] = -kmax
    status, k, u = nnls_least_distance(m_mat, e, cost, float(np.max(np.abs(np.r_[kmin, kmax]), initial=0.0)))
    if status != "optimal" or k is None or u is None:
        return status, None
    lam = np.zeros(b.size)
    lam[keep] = u[:n_rows]
    return "optimal", (k, lam, u[n_rows:n_rows + n], u[n_rows + n:])


def nnls_least_distance(m_mat: Array, e: Array, cost: Array, box: float) -> tuple[str, Array | None, Array | None]:
    """Solve min Σ c k² s.t. M k ≥ m through u = NNLS(E, e_{n+1}) (see :func:`least_distance`).

    Parameters
    ----------
    m_mat : ndarray of shape (m, n)
        The constraint rows M.
    e : ndarray of shape (n + 1, m)
        E = [(M/√c)ᵀ; mᵀ]: the last row holds the right-hand sides m.
    cost : ndarray of shape (n,)
    box : float
        max |k| over the true box, for the Farkas check of an infeasible system.

    Returns
    -------
    status : ``"optimal"``, ``"infeasible"`` (checked certificate) or ``"unknown"``
    k : ndarray of shape (n,) or None
    u : ndarray of shape (m,) or None
        Multipliers of the rows, ≥ 0, up to one positive scale.
    """
    from scipy.optimize import nnls

    n = cost.size
    f = np.zeros(n + 1)
    f[-1] = 1.0
    try:
        u, _ = nnls(e, f, maxiter=50 * e.shape[1])
    except RuntimeError:  # iteration limit
        return "unknown", None, None
    r = e @ u - f
    if abs(r[-1]) > 1e-9:
        return "optimal", -r[:n] / r[-1] / np.sqrt(cost), u
    eps = m_mat.T @ u
    s = float(e[-1] @ u)
    if s > 0 and float(np.sum(np.abs(eps))) * box < s:
        return "infeasible", None, None
    return "unknown", None, None


def least_distance_system(rows: Array, cost: Array) -> tuple[Array, Array]:
    """The part of :func:`least_distance`'s NNLS system that does not depend on b.

    Returns M = [−rows; I; −I] (shape (r + 2n, n)) and E = [(M/√c)ᵀ; 0] (shape (n + 1, r + 2n)),
    whose last row :func:`least_distance` fills with the right-hand sides.
    """
    n = cost.size
    m_mat = np.vstack([-rows, np.eye(n), -np.eye(n)])
    e = np.vstack([(m_mat * (1.0 / np.sqrt(cost))).T, np.zeros((1, m_mat.shape[0]))])
    return m_mat, e


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
                   rows: Array | None = None, rhs: Array | None = None, fmax: float = np.inf,
                   work_limit: int = WORK_LIMIT,
                   multipliers: tuple[Array, Array, Array] | None = None) -> npt.NDArray[np.float64] | None:
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
        return grid[keep]
    if np.isfinite(f_slack):
        order = np.argsort(-np.sqrt(cost) * np.abs(centre), kind="stable")
    else:
        order = np.argsort(counts_all, kind="stable")  # fewest candidates first keeps the lists short
    c, ce, lo_o, hi_o = cost[order], centre[order], lo_all[order], hi_all[order]

    def after(x: Array) -> Array:  # after(x)[..., p] = Σ_{q > p} x[..., q]
        s = np.cumsum(x[..., ::-1], axis=-1)[..., ::-1]
        return np.concatenate([s[..., 1:], np.zeros(s.shape[:-1] + (1,))], axis=-1)

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
        top = np.minimum(np.sum(np.maximum(a * lo_o, a * hi_o), axis=1),
                         a @ ce + np.sqrt(max(radius2, 0.0)) * np.sqrt(np.sum(a * a / c, axis=1)))
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


def ellipsoid_search(g_rows: Array, g: Array, level: float, centre: Array, q: float, cost: Array, kmin: Array,
                     kmax: Array, f_known: float, limit: int, b: Array | None = None,
                     work_limit: int = WORK_LIMIT,
                     multipliers: tuple[Array, Array, Array] | None = None) -> tuple[Array | None, bool, int]:
    """Least Σ c k² among grid points with t(k) ≥ level, by growing ellipsoids around ``centre``.

    Every feasible k satisfies Σ c (k − centre)² ≤ f(k) − q (:func:`lagrangian_ball`).
    Radii² 1, 4, 16, … up to f − q (f: the least norm of a feasible point known so far,
    ``f_known`` at first, or inf), or up to the radius² that holds the whole box, are listed in turn, only points of norm ≤ f (pruned by
    the rows G k ≤ b, which every feasible point meets, when ``b`` is given); as soon as
    the best feasible point found, of norm f_b, has f_b − q ≤ the radius² listed, nothing
    outside can beat it and it is the least (ties: the lexicographically smallest k).
    ``multipliers`` (λ of the rows G k ≤ b, of k ≥ kmin and of k ≤ kmax; any λ ≥ 0) sharpen
    the pruning by the norm (:func:`enumerate_ball`).

    Returns
    -------
    best : ndarray of shape (n,) or None
        The least feasible point found with f < f_known (None: none better).
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
            points = enumerate_ball(centre, cost, radius2, kmin, kmax, limit, g_rows[fin], b[fin], fmax=f_cut,
                                    work_limit=work_limit, multipliers=lam)
        if points is None:
            return best, False, listed
        listed = points.shape[0]
        if listed:
            ok = points[grid_margins(g_rows, g, points) >= level - TOL]
            if ok.shape[0]:
                f = np.sum(cost * ok**2, axis=1)
                order = np.lexsort((*ok.T[::-1], f))  # least norm, ties by the smallest k
                if f[order[0]] < f_known:
                    best = ok[order[0]]
                    f_cut = float(f[order[0]])
                    cap = min(cap, room(f_cut))
                    if f_cut - q <= radius2:
                        return best, True, listed
        if radius2 >= cap:
            return best, True, listed
        radius2 = min(radius2 * 4, cap)

