"""Proofs on the register grid that spare the exact optimiser a MILP.

Everything is in grid units: corrections k (integer steps), margin rows
``m_j(k) = g_j − G_j·k`` and the error budget ``t(k) = min_j m_j(k)`` (see
:func:`setupfix.optimize.exact.solve.margin_rows`).  Each function returns a bound or a
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

Least norm among grid points with t(k) ≥ t*: the listing of the dual ellipsoid
(:mod:`setupfix.optimize.exact.least_norm.listing`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "TOL",
    "PairStructure",
    "dual_bound",
    "grid_margins",
    "is_network",
    "least_distance",
    "least_distance_system",
    "next_level",
    "nnls_least_distance",
    "pair_bound",
    "pair_structure",
    "rounded_rhs",
    "row_gcd",
]

Array = npt.NDArray[np.float64]

#: Tolerance of every comparison of margins [grid steps].  Deviations are quantised to
#: 1/1000 step before solving, so distinct margins from one dimension differ by far more.
TOL = 1e-9

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
        return np.array((g - g_rows @ k).min())
    out = np.empty(k.shape[0])
    step = max(1, _BLOCK // max(g.size, 1))
    for s in range(0, k.shape[0], step):
        out[s : s + step] = np.min(g[None, :] - k[s : s + step] @ g_rows.T, axis=1)
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
    pairs = [
        (i, j) for i, j in enumerate(negated) if i < j and np.any(rows[i]) and np.array_equal(rows[j], -rows[i] + 0.0)
    ]
    if not pairs:
        return None
    ia, ib = (np.array(v, dtype=np.intp) for v in zip(*pairs, strict=True))
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


def rounded_rhs(g: Array, d: Array, zero: npt.NDArray[np.bool_], tau: float | Array) -> Array:
    """Right-hand sides b with {k : G k ≤ b} ⊇ {grid k : t(k) ≥ τ}.

    ``tau`` may be one level or one per row (shape (r,): the leximin levels' floors).

    Integer rows (d > 0): d·⌊(g − τ)/d⌋ (with 1e-7 slack: rounding up a value a hair
    below an integer only relaxes); zero rows (``zero``): +inf when g ≥ τ, else −1
    (0 ≤ −1: empty); other rows: g − τ + TOL.
    """
    diff = g - tau  # shape (r,): one pass over every row (a level of −inf gives +inf: no row)
    integer = d > 0
    step = np.where(integer, d, 1.0)
    b = np.where(integer, step * np.floor(diff / step + 1e-7), diff + TOL)
    if zero.any():
        b[zero] = np.where(diff[zero] >= -TOL, np.inf, -1.0)
    return b


def is_network(g_rows: Array) -> bool:
    """Whether G is totally unimodular as a network matrix after flipping the signs of some columns.

    True when every row has at most two non-zero entries, each ±1, and the columns can be signed so
    that every row with two entries holds one +1 and one −1 (one WKS and one tool per dimension: a
    2-colouring of the columns with parities, checked by union–find).  Then {G k ≤ b, box} with
    integer b and box has integral vertices: a feasible LP's vertex is a grid point.
    """
    nz = g_rows != 0
    if g_rows.size == 0 or np.any(np.abs(g_rows[nz]) != 1) or np.any(nz.sum(axis=1) > 2):
        return False
    n = g_rows.shape[1]
    parent = list(range(n))
    parity = [0] * n  # sign of a column relative to its root (0: same, 1: flipped)

    def find(i: int) -> tuple[int, int]:
        p = 0
        while parent[i] != i:
            p ^= parity[i]
            i = parent[i]
        return i, p

    for row in np.flatnonzero(nz.sum(axis=1) == 2):
        a, b = np.flatnonzero(nz[row])
        need = 0 if g_rows[row, a] != g_rows[row, b] else 1  # flipped relative to each other?
        (ra, pa), (rb, pb) = find(int(a)), find(int(b))
        if ra == rb:
            if pa ^ pb != need:
                return False
        else:
            parent[ra] = rb
            parity[ra] = pa ^ pb ^ need
    return True


def next_level(g: Array, d: Array, b: Array) -> float:
    """Largest τ' such that the system rounded at any level in (τ', τ] is ``b``.

    Only for systems whose rows are all integer (d > 0) or zero: then an empty
    rounded system at τ proves t(k) ≤ τ' for every grid point with t(k) ≤ τ.
    """
    m = d > 0
    return float(np.max(g[m] - b[m] - d[m])) if np.any(m) else -np.inf


def least_distance(
    g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array, system: tuple[Array, Array] | None = None
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
    e[-1, n_rows : n_rows + n] = kmin
    e[-1, n_rows + n :] = -kmax
    status, k, u = nnls_least_distance(m_mat, e, cost, float(np.max(np.abs(np.concatenate((kmin, kmax))), initial=0.0)))
    if status != "optimal" or k is None or u is None:
        return status, None
    lam = np.zeros(b.size)
    lam[keep] = u[:n_rows]
    return "optimal", (k, lam, u[n_rows : n_rows + n], u[n_rows + n :])


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
