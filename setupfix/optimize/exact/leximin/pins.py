"""Which margins a leximin level set holds fixed: weak-duality certificates and the span of pinned rows.

Grid units as in :mod:`setupfix.optimize.exact.session`.  A *level set* L is the set of grid points
with every fixed dimension at least its floor and every active one at least the level t
(:mod:`setupfix.optimize.exact.leximin.levels`).  A row j is *pinned* on L when G_j k takes one value at every
point of L; a dimension all of whose rows are pinned has the same margin at every point of L, so
it can be fixed at that margin without losing any leximin-optimal point.  Both proofs here are
checked in numpy, whatever the solver's tolerances:

* :func:`pinned_rows` — weights y ≥ 0 from an LP on the rows (its duals) give, for every k in
  the box, ``Σ y_j (rhs_j − G_j k) ≤ C`` with C computed here; on L each term is at least its
  floor, so a row's term cannot exceed its floor by more than (C − Σ y floor)/y_j.  Below the
  tie threshold ε on a level LP's active row: *saturated* (its margin is t on L).  Below the
  row's gcd d_j on rounded rows (where ``rhs_j − G_j k`` is a multiple of d_j): *pinned*.
* :func:`span_closure` — if every row in P is pinned on L, so is every row in the real span of
  P: ``G_j = Σ λ_p G_p`` gives ``G_j k = Σ λ_p G_p k``.  For integer rows the test is exact: an
  integer row outside span(P) is at distance ≥ 1/√det Gram(B) from it (B a basis of P's rows,
  Gram integer), and Hadamard's inequality bounds det Gram(B) by the product of the rank largest
  squared row norms; when that bound is too large to separate the two cases in floating point,
  only rows equal or opposite to a pinned row are added.

The tests of single grid points — whether one meets given floors (:func:`point_above`), Farkas
weights or a point by NNLS (:func:`~setupfix.optimize.exact.farkas.farkas_or_point`), roundings — answer
with a point checked on the rows or a proof that none exists.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.farkas import farkas_or_point
from setupfix.optimize.exact.grid import TOL, rounded_rhs
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.leximin.search import group_min
from setupfix.optimize.exact.session import GridRows, Session
from setupfix.optimize.exact.work import charge, now

__all__ = [
    "Certificates",
    "LevelStep",
    "best_rounding",
    "dim_all",
    "dim_margins",
    "excluded_alone",
    "level_bound",
    "meeting_rounding",
    "pinned_rows",
    "point_above",
    "span_closure",
]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: Largest Hadamard bound on det Gram(B) for which the span test is decided in floating point
#: (an integer row outside the span is then ≥ 1e-5 away; float error is ~1e-12).
_HADAMARD_MAX = 1e10
#: The floor/ceil choices of 0 … 5 fractional coordinates (one row per choice, bit i: coordinate i up).
_BITS = [(np.arange(1 << f)[:, None] >> np.arange(f)) & 1 for f in range(6)]
#: Absolute margin on a certificate's weighted sum (weights summing to 1) before it pins a row.
_MARGIN = 1e-9


@dataclass(frozen=True)
class Certificates:
    """Row weights to check by weak duality.

    Attributes
    ----------
    g_rows : ndarray of shape (r, n); kmin, kmax : ndarray of shape (n,)
    certificates : tuple of (weights (r,), rhs (r,), floors (r,), rounded)
        ``rhs_j − G_j k ≥ floors_j`` at every point of the level set; ``rounded``: rhs on the
        lattice of G_j k (``rhs_j − G_j k`` a multiple of d_j there).
    """

    g_rows: Array
    kmin: Array
    kmax: Array
    certificates: tuple[tuple[Array, Array, Array, bool], ...]


@dataclass(frozen=True)
class LevelStep:
    """A level by the rounded rows at a grid point's own level (:meth:`LevelModel.step`).

    ``proved``: no grid point of the level set has every active margin ≥ t + ε, and
    ``certificates`` are the LP's weights (they pin rows); else the best point reached (the
    caller proves the level otherwise; ``stop``: the limit or HiGHS stopped the step).
    """

    t: float
    k: Array
    proved: bool
    certificates: Certificates | None
    stop: str | None
    calls: int
    x: Array | None = None  # the proving LP's point (k part): rounded, often the next level's point


def pinned_rows(level: Certificates, active_rows: Mask, eps: float, d: Array) -> tuple[Mask, Mask]:
    """Active rows whose margin cannot rise above t + ε (saturated), and integer rows pinned on L.

    For weights y (normalised to sum 1) and every k in the box
    ``Σ_j y_j (rhs_j − G_j k) ≤ C = yᵀrhs + Σ_i max(−w_i kmin_i, −w_i kmax_i)``, w = Gᵀy.  On the
    level set every term is ≥ y_j floor_j, so ``rhs_j − G_j k − floor_j ≤ (C − yᵀfloor)/y_j``.

    Parameters
    ----------
    level : Certificates
    active_rows : ndarray of bool, shape (r,)
        Rows of active dimensions (only these can be saturated).
    eps : float
        Tie threshold [steps].
    d : ndarray of shape (r,)
        Row gcds (0: not an integer row).

    Returns
    -------
    saturated, pinned : ndarray of bool, shape (r,)
    """
    sat = np.zeros(active_rows.size, bool)
    pin = np.zeros(active_rows.size, bool)
    for weights, rhs, floors, rounded in level.certificates:
        y = np.maximum(weights, 0.0)
        total = float(y.sum())
        if not np.isfinite(total) or total <= 0:
            continue
        y = y / total
        w = y @ level.g_rows
        c = float(y @ rhs + np.maximum(-w * level.kmin, -w * level.kmax).sum())
        # slack and y_j·room compared with an absolute margin (y sums to 1, the numbers are ~1e2: the
        # rounding error of slack is ~1e-12), so a weight of 1e-17 never turns a rounding error into a pin
        slack = c - float(y @ floors) + _MARGIN
        if rounded:
            pin |= (d > 0) & (y * (d - 1e-7) > slack)
        else:
            sat |= active_rows & (y * (eps - 1e-9) >= slack)
    return sat, pin


def span_closure(g_rows: Array, d: Array, pinned: Mask, key: Array) -> Mask:
    """Integer rows in the real span of the pinned integer rows (a superset of ``pinned``'s integer rows).

    ``key``: a random integer projection of the rows (equal or opposite rows, equal |key|), used
    when the span test cannot be decided exactly (see the module text).
    """
    integer = d > 0
    base = pinned & integer
    if not base.any():
        return pinned.copy()
    p = g_rows[base]
    charge(p.shape[0] * p.shape[1] * min(p.shape) / 1e4)  # the SVD's work (work units, not time)
    sq = np.sort(np.einsum("ij,ij->i", p, p))[::-1]
    _, s, vt = np.linalg.svd(p, full_matrices=False)
    rank = int(np.sum(s > 1e-9 * s[0]))
    if float(np.prod(sq[:rank])) <= _HADAMARD_MAX:
        basis = vt[:rank]
        cand = integer & ~base
        rest = g_rows[cand] - (g_rows[cand] @ basis.T) @ basis
        out = pinned.copy()
        out[cand] = np.einsum("ij,ij->i", rest, rest) < 0.25 / _HADAMARD_MAX
        return out | pinned
    out = pinned.copy()  # equal or opposite rows only (checked, not only keyed)
    charge(int(base.sum()) * g_rows.shape[0] / 50)
    for j in np.flatnonzero(base):
        idx = np.flatnonzero(integer & ~out & (np.abs(key) == abs(key[j])))
        same = np.all(g_rows[idx] == g_rows[j], axis=1) | np.all(g_rows[idx] == -g_rows[j], axis=1)
        out[idx[same]] = True
    return out


def dim_all(
    rows_mask: Mask, order: npt.NDArray[np.intp], starts: npt.NDArray[np.intp], dims: npt.NDArray[np.intp], n_dims: int
) -> Mask:
    """Dimensions with at least one row, every one of them in ``rows_mask`` — shape (n_dims,).

    Rows grouped by dimension: ``order`` sorts them, group g starts at ``starts[g]`` and is
    dimension ``dims[g]`` (:class:`~setupfix.optimize.exact.leximin.level.LevelModel`)."""
    out = np.zeros(n_dims, bool)
    out[dims] = np.logical_and.reduceat(rows_mask[order], starts)
    return out


def best_rounding(
    rows: GridRows,
    x: Array,
    floors: Array,
    active_dims: Mask,
    order: npt.NDArray[np.intp],
    starts: npt.NDArray[np.intp],
    most: int = 4,
) -> tuple[Array, float]:
    """A good rounding of x and its level (min active margin; −inf below a fixed floor).

    Every floor/ceil choice of the ``most`` fractional coordinates nearest ½ (the others to the
    nearest integer) is evaluated — a point to try, nothing is proved by it; ties by the active
    dimensions' sorted margins (leximin: a point for the next levels too).  ``floors``: per row
    (NaN: active); ``order``/``starts``: the rows grouped by dimension
    (:func:`~setupfix.optimize.exact.leximin.search.group_min`);
    ``active_dims``: per group.
    """
    kmin, kmax = rows.kmin, rows.kmax  # np.minimum/np.maximum: a few µs less than np.clip on these sizes
    lo = np.minimum(np.maximum(np.floor(x + 1e-9), kmin), kmax)
    near = np.minimum(np.maximum(np.rint(x), kmin), kmax)
    frac = np.flatnonzero(np.abs(x - near) > 1e-6)
    if frac.size > 1:
        frac = frac[np.argsort(np.abs(x[frac] - lo[frac] - 0.5), kind="stable")[:most]]
    cand = np.repeat(near[None, :], 1 << frac.size, axis=0)
    if frac.size:
        bits = (
            _BITS[frac.size]
            if frac.size < len(_BITS)
            else ((np.arange(1 << frac.size)[:, None] >> np.arange(frac.size)) & 1)
        )
        cand[:, frac] = np.minimum(np.maximum(lo[frac] + bits, kmin[frac]), kmax[frac])
    fixed = ~np.isnan(floors)
    charge(cand.shape[0] * rows.g_rows.size / 1e4)
    m = rows.g - cand @ rows.g_rows.T
    level = np.where(fixed, np.inf, m).min(axis=1)
    with np.errstate(invalid="ignore"):  # NaN floors (active rows) compare False
        level[(m < floors - TOL).any(axis=1)] = -np.inf
    top = np.flatnonzero(level >= level.max() - 1e-9)
    i = int(top[0])
    if top.size > 1 and np.isfinite(level[i]):
        by_dim = group_min(m[top][:, order], starts)
        sorted_m = np.sort(by_dim[:, active_dims], axis=1)
        i = int(top[np.lexsort(np.round(sorted_m, 6).T[::-1])[-1]])
    return cand[i], float(level[i])


def level_bound(rows: GridRows, y: Array, rhs: Array, active_rows: Mask) -> float:
    """Bound on the level from row weights y ≥ 0 (weak duality).

    ``rhs``: g_j on active rows, g_j − v_q(j) on fixed ones (+inf: left out).  Over the box
    Σ_A y_j m_j + Σ_F y_j (rhs_j − G_j k) ≤ C; on the level set every term is ≥ t resp. 0, so
    t ≤ C / Σ_A y_j.
    """
    fin = np.isfinite(rhs)
    y = np.where(fin, np.maximum(y, 0.0), 0.0)
    total = float(y[active_rows].sum())
    if total <= 0:
        return np.inf
    w = y @ rows.g_rows
    c = float(y @ np.where(fin, rhs, 0.0) + np.sum(np.maximum(-w * rows.kmin, -w * rows.kmax)))
    return c / total


def dim_margins(
    g_rows: Array,
    g: Array,
    k: Array,
    order: npt.NDArray[np.intp],
    starts: npt.NDArray[np.intp],
    dims: npt.NDArray[np.intp],
    n_dims: int,
) -> Array:
    """Margin of each dimension at k: the least of its rows' ``g_j − G_j k`` (inf: no row) — shape (n_dims,);
    rows grouped as in :func:`dim_all`."""
    out = np.full(n_dims, np.inf)
    out[dims] = np.minimum.reduceat((g - g_rows @ k)[order], starts)
    return out


def excluded_alone(
    rows: GridRows,
    floors: Array,
    row_dim: npt.NDArray[np.intp],
    n_dims: int,
    t: float,
    eps: float,
    together: int = 1,
    near: Array | None = None,
) -> Mask:
    """Active dimensions (``together`` = 2: pairs of them) proved unable to be the only ones left at level t,
    by one Farkas certificate.

    ``floors``: per row (NaN: active).  b: every active row rounded at t + ε, fixed rows at their
    floors; weights y ≥ 0 (sum 1) with ``max over the box of Σ y_j (b_j − G_j k) = W < 0``
    (:func:`~setupfix.optimize.exact.farkas.farkas_or_point`) prove that no point meets G k ≤ b.  Lowering
    dimension q's rows to t raises b_j by δ_j on them only, so the same weights still prove "no point" when
    W + Σ_{j ∈ q} y_j δ_j < 0: no grid point has every active dimension but q above t + ε (q ≥ t);
    for a pair q, p (rows of one dimension only), W + Σ_{j ∈ q} y_j δ_j + Σ_{j ∈ p} y_j δ_j < 0.
    Returns a mask of shape (n_dims,), or (n_dims, n_dims) for pairs (symmetric; all False when NNLS
    finds no certificate).  ``near``: a grid point of the level set; the certificate is then sought
    among the rows near it only (``farkas_or_point(..., whole=False)``: NNLS on a fraction of the
    columns, and weights on few rows exclude the most); None: on the whole system.
    """
    out = np.zeros((n_dims,) * together, bool)
    active = np.isnan(floors)
    level = np.where(active, t + eps, floors)
    fin = np.isfinite(level)
    b_up = np.full(level.size, np.inf)
    b_up[fin] = rounded_rhs(rows.g[fin], rows.d[fin], rows.zero[fin], level[fin])
    y = farkas_or_point(rows, b_up, near, whole=near is None)[0]
    if y is None:
        return out
    b_at = b_up.copy()
    b_at[active] = rounded_rhs(rows.g[active], rows.d[active], rows.zero[active], np.full(int(active.sum()), t))
    w = y @ rows.g_rows
    worst = float(y @ np.where(np.isfinite(b_up), b_up, 0.0) + np.sum(np.maximum(-w * rows.kmin, -w * rows.kmax)))
    with np.errstate(invalid="ignore"):
        rise = np.where(active & (y > 0), y * (b_at - b_up), 0.0)  # inf·0 never: y > 0 only on finite rows
    extra = np.zeros(n_dims)
    np.add.at(extra, row_dim, rise)
    dims_active = np.zeros(n_dims, bool)
    dims_active[row_dim[active]] = True
    if together == 2:
        return dims_active[:, None] & dims_active[None, :] & (worst + extra[:, None] + extra[None, :] < -1e-9)
    return dims_active & (worst + extra < -1e-9)


def meeting_rounding(rows: GridRows, x: Array, f: Array, most: int = 10) -> Array | None:
    """A floor/ceil rounding of x (up to ``most`` fractional coordinates; the others to the nearest
    integer) with every row's margin ≥ f_j (shape (r,), −inf: no floor), or None — checked exactly."""
    lo = np.clip(np.floor(x + 1e-9), rows.kmin, rows.kmax)
    near = np.clip(np.rint(x), rows.kmin, rows.kmax)
    frac = np.flatnonzero(np.abs(x - near) > 1e-6)[:most]
    if frac.size == 0:
        return None
    bits = (np.arange(1 << frac.size)[:, None] >> np.arange(frac.size)) & 1
    choice = np.clip(lo[frac] + bits, rows.kmin[frac], rows.kmax[frac])  # (2^f, f)
    # each candidate differs from ``near`` by at most one step on the fractional coordinates only: a row
    # whose slack at ``near`` covers Σ|G_j,frac| holds for all (f = −inf: infinite slack); the others are
    # checked on those coordinates, (2^f, f) @ (f, r') rather than (2^f, n) @ (n, r)
    with np.errstate(invalid="ignore"):
        slack = rows.g - rows.g_rows @ near - f
    g_frac = rows.g_rows[:, frac]
    at_risk = np.flatnonzero(slack < np.abs(g_frac).sum(axis=1) - 1e-9)
    slack_c = slack[at_risk][None, :] - (choice - near[frac]) @ g_frac[at_risk].T
    hit = np.flatnonzero(np.all(slack_c >= -1e-9, axis=1))
    if not hit.size:
        return None
    out = near.copy()
    out[frac] = choice[int(hit[0])]
    return out


def point_above(session: Session, f: Array, stage_end: float) -> Array | bool | None:
    """A grid point with every row's margin ≥ f_j (shape (r,), −inf: no floor); False: proved none; None:
    the limit or HiGHS stopped it.

    Cheapest first, each answer checked: NNLS on the rows rounded at f (small problems: a Farkas
    certificate, or a point to round); the LP of those rows (infeasible, or its vertex rounded);
    then MILPs — first of the rows within ``settings.tight_slack`` steps of the vertex (no grid point meets
    them: none meets all, in ~0.6 ms where the MILP of all rows takes ~6 ms on the paper's example,
    ``bench/results/point_tests.txt``; a point of theirs that meets every row is one), then of all rows.
    """
    if now() >= stage_end:  # the stage's share is spent: no test starts (a loop of them stops)
        return None
    rows = session.rows
    n = rows.n_free
    fin = np.isfinite(f)
    b = rounded_rhs(rows.g, rows.d, rows.zero, f)  # +inf where f is −inf

    def meets(k: Array) -> bool:
        return bool(np.all((rows.g - rows.g_rows @ k)[fin] >= f[fin] - 1e-9))

    if rows.all_integer and session.small:  # NNLS first (~0.1 ms): a proof, or a point to round
        y, x_ld = farkas_or_point(rows, b)
        if y is not None:
            return False
        if x_ld is not None:
            k = np.clip(np.rint(x_ld), rows.kmin, rows.kmax)
            k_met = k if meets(k) else meeting_rounding(rows, x_ld, f)
            if k_met is not None:
                return k_met
    kx = None
    if rows.all_integer:
        feas, kx = session.rounded_rows_feasible(b, stage_end - now(), warm=True)
        if feas == "infeasible":
            return False
        if feas != "optimal":
            return None
        if kx is not None:  # the vertex rounded, else each floor/ceil choice of its fractional coordinates
            k = np.clip(np.rint(kx), rows.kmin, rows.kmax)
            k_met = k if meets(k) else meeting_rounding(rows, kx, f)
            if k_met is not None:
                return k_met
    tight = fin & (b - rows.g_rows @ kx < session.settings.tight_slack) if kx is not None else fin
    for keep in (tight, fin) if tight.sum() < fin.sum() else (fin,):
        res = LinearModel(
            np.zeros(n),
            rows.g_rows[keep],
            np.full(int(keep.sum()), -INF),
            b[keep],
            rows.kmin,
            rows.kmax,
            integer=np.ones(n, bool),
        ).solve(stage_end - now())
        if res.status == "infeasible":
            return False
        k_mip = None if res.x is None else np.clip(np.rint(res.x), rows.kmin, rows.kmax)
        if k_mip is not None and meets(k_mip):
            return k_mip
        if res.status == "time_limit" or now() >= stage_end:
            return None
    return None
