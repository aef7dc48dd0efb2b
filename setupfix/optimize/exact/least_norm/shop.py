"""Least norm on the register grid at shop scale (eq. 9 for hundreds of registers).

Everything is in grid units (k = x / resolution; rows ``G k ≤ b`` hold every grid
point whose error budget reaches the proven optimum, see
:func:`setupfix.optimize.exact.grid.rounded_rhs`); f(k) = Σ c_i k_i².

The pieces, each with what proves it:

* :func:`least_distance_working_set` — the continuous least-norm point and its
  multipliers by NNLS (Lawson & Hanson) on a working set of rows: rows are added
  where the current point violates them, so the solved systems stay a few hundred
  rows whatever the number of dimensions.  The answer satisfies every row (checked
  here), so it is the optimum of the whole problem; an empty working set proves
  the whole problem empty (Farkas, checked against the box).  HiGHS's QP solver
  stalled on one of the 300 × 5,000 problems of ``bench/exact_scaling.py`` (seed 1).
* :func:`lagrangian_box` — with the centre κ and value q of
  :func:`~setupfix.optimize.exact.least_norm.listing.lagrangian_ball`, f(k) ≥ q + Σ c_i (k_i − κ_i)²
  for every feasible k; on integers the right side is at least
  LB = q + Σ d_i (d_i: the least c_i (k_i − κ_i)² over integer k_i), a certified
  lower bound on the grid least norm, and every feasible k with f(k) ≤ F lies in the
  box c_i (k_i − κ_i)² ≤ F − LB + d_i.  The least norm can be searched in that box
  only.
* :func:`box_least_norm` — the least norm restricted to a box, as one MILP whose
  objective is exact on the box's integers (k² is the upper envelope of the chords
  through consecutive integers; on a box of two values per coordinate it is linear).
  Around the rounded continuous point it gives a near-least incumbent quickly.
* :func:`chord_least_norm` — the exact least norm over a box by the chords of k²,
  added lazily (an LP first; a MILP when the LP's vertex is fractional).
* :func:`network_rows` — whether the rows are a network matrix after flipping some
  columns (one WKS and one tool per dimension, coefficients ±1): then the chord LP's
  vertex is on the grid, and :func:`chord_least_norm`'s first LP is the proof.
* :func:`descend` — coordinate descent on the grid that keeps every row: each move
  takes one coordinate to the value of least c_i k_i² its feasible range allows;
  the norm never grows.  Used when a limit stops the proof.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array, hstack, vstack
from scipy.sparse.csgraph import connected_components

from setupfix.optimize.exact.grid import TOL, grid_margins, nnls_least_distance
from setupfix.optimize.exact.highs import INF, LinearModel, Solve
from setupfix.optimize.exact.least_norm.chords import chord_rows, lazy_chords
from setupfix.optimize.exact.work import now

__all__ = [
    "box_least_norm",
    "chord_least_norm",
    "descend",
    "lagrangian_box",
    "least_distance_working_set",
    "lower_bound_ratio",
    "network_rows",
]

Array = npt.NDArray[np.float64]

#: Rows added to the working set per round (the most violated first).
WORKING_SET_ADD = 100
#: A box MILP with at most this many matrix elements is built as one dense array.
DENSE_MAX_ELEMENTS = 200_000


def _nnls_least_distance(m_mat: Array, m_vec: Array, cost: Array, box: float) -> tuple[str, Array | None, Array | None]:
    """min Σ c k² s.t. M k ≥ m by NNLS; ``box`` = max |k| over the true box (for the Farkas check).

    Returns ``(status, k, u)``: u ≥ 0 are the multipliers of the rows, up to one positive scale.
    """
    e = np.vstack([(m_mat / np.sqrt(cost)).T, m_vec[None, :]])
    return nnls_least_distance(m_mat, e, cost, box)


def least_distance_working_set(
    g_rows: Array, b: Array, kmin: Array, kmax: Array, cost: Array, deadline: float, add: int = WORKING_SET_ADD
) -> tuple[str, tuple[Array, Array, Array, Array] | None]:
    """Least Σ c k² subject to G k ≤ b and the box, by NNLS on a growing working set of rows.

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); b : ndarray of shape (r,) (+inf: no row)
    kmin, kmax, cost : ndarray of shape (n,)
    deadline : float
        ``now()`` value after which the answer is ``"unknown"``.
    add : int
        Most rows added per round.

    Returns
    -------
    status : str
        ``"optimal"``, ``"infeasible"`` (a checked Farkas certificate of a subset of the
        rows) or ``"unknown"`` (deadline, or NNLS's iteration limit).
    solution : (k, λ_rows, λ_lower, λ_upper) or None
        The point (every row and bound holds to 1e-7) and multipliers ≥ 0 (one common
        scale; zero outside the working set).
    """
    r, n = g_rows.shape
    fin = np.isfinite(b)
    # every constraint as a row a·k ≤ c: G's rows, then k ≤ kmax, then −k ≤ −kmin
    c_all = np.r_[np.where(fin, b, np.inf), kmax, -kmin]
    box = float(np.max(np.abs(np.r_[kmin, kmax]), initial=0.0))

    def lhs(k: Array) -> Array:
        stacked: Array = np.r_[g_rows @ k, k, -k]
        return stacked

    def row(idx: npt.NDArray[np.intp]) -> Array:
        out = np.zeros((idx.size, n))
        g_part = idx < r
        out[g_part] = g_rows[idx[g_part]]
        up = (idx >= r) & (idx < r + n)
        out[up, idx[up] - r] = 1.0
        lo = idx >= r + n
        out[lo, idx[lo] - r - n] = -1.0
        return out

    work = np.zeros(0, dtype=np.intp)
    k = np.zeros(n)
    u = np.zeros(0)
    while True:
        viol = lhs(k) - c_all
        viol[work] = -np.inf
        new = np.flatnonzero(viol > 1e-9)
        if new.size == 0:
            lam = np.zeros(r + 2 * n)
            lam[work] = u
            return "optimal", (k, lam[:r], lam[r + n :], lam[r : r + n])
        if now() > deadline:
            return "unknown", None
        new = new[np.argsort(-viol[new], kind="stable")[:add]]
        work = np.r_[work, new]
        status, k_new, u_new = _nnls_least_distance(-row(work), -c_all[work], cost, box)
        if status != "optimal" or k_new is None or u_new is None:
            return status, None
        k, u = k_new, u_new


def lagrangian_box(
    centre: Array, q: float, cost: Array, kmin: Array, kmax: Array, f_best: float
) -> tuple[Array, Array, float]:
    """Box holding every grid point of norm ≤ ``f_best``, and the certified lower bound LB.

    Parameters
    ----------
    centre, q
        From :func:`~setupfix.optimize.exact.least_norm.listing.lagrangian_ball` (f(k) ≥ Σ c (k − centre)² + q
        for every feasible k).
    cost, kmin, kmax : ndarray of shape (n,)
    f_best : float
        Norm Σ c k² of a feasible grid point.

    Returns
    -------
    lo, hi : ndarray of shape (n,)
        Integer bounds; lo > hi somewhere when no grid point reaches ``f_best``.
    lower : float
        LB = q + Σ_i min_{integer k_i in the box} c_i (k_i − centre_i)² ≤ f(k) for every
        feasible grid point k.
    """
    near = np.clip(np.rint(centre), kmin, kmax)
    d = cost * (near - centre) ** 2
    lower = float(q + d.sum())
    room = f_best - lower + 1e-9 * max(1.0, abs(f_best))
    half = np.sqrt(np.maximum(room + d, 0.0) / cost)
    lo = np.maximum(np.ceil(centre - half - 1e-9), kmin)
    hi = np.minimum(np.floor(centre + half + 1e-9), kmax)
    if room < 0:
        lo, hi = hi + 1, hi
    return lo, hi, lower


def box_least_norm(
    g_rows: Array,
    b: Array,
    lo: Array,
    hi: Array,
    cost: Array,
    time_limit: float,
    start: Array | None = None,
    proof: bool = False,
    gap: float = 0.0,
) -> tuple[Solve, Array | None]:
    """Least Σ c k² over integer k in [lo, hi] with G k ≤ b, as one exact MILP.

    On each coordinate's integers k² is the upper envelope of the chords
    s ≥ (2j+1)·k − j(j+1), j = lo … hi−1 (signed k), so the MILP's optimum is the
    least norm in the box.  Coordinates with two values need no chord: there k² is
    linear, lo² + (2·lo+1)(k − lo).

    ``proof``: ``start`` is near-least already (see
    :meth:`~setupfix.optimize.exact.highs.LinearModel.prefer_proof`).  ``gap``: HiGHS may stop at
    this relative gap (an incumbent is wanted, not a proof; the result's ``status`` is then
    ``optimal`` without proving the box's least norm).

    Returns
    -------
    solve : Solve
        HiGHS's outcome (``dual_bound`` is a lower bound on the norm in the box).
    k : ndarray of shape (n,) or None
        The best integer point found.
    """
    n = lo.size
    fin = np.isfinite(b)
    width = (hi - lo).astype(np.int64)
    chorded = np.flatnonzero(width >= 2)
    # two values: c·k² = c·(2·lo+1)·k − c·(lo² + lo); one value: the constant c·lo²
    linear = np.where(width == 1, cost * (2 * lo + 1), 0.0)
    const = float(
        np.sum(np.where(width == 0, cost * lo**2, 0.0)) - np.sum(np.where(width == 1, cost * (lo**2 + lo), 0.0))
    )
    counts = width[chorded]
    i = np.repeat(chorded, counts)
    j = np.repeat(lo[chorded], counts) + np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    m = i.size
    col = np.full(n, -1, dtype=np.int64)
    col[chorded] = n + np.arange(chorded.size)
    r = int(fin.sum())
    a: object
    if (r + m) * (n + chorded.size) <= DENSE_MAX_ELEMENTS:  # small: one dense array (same matrix, less overhead)
        a = np.zeros((r + m, n + chorded.size))
        a[:r, :n] = g_rows[fin]
        a[r + np.arange(m), i] = 2 * j + 1
        a[r + np.arange(m), col[i]] = -1.0
    else:
        chords = csr_array(
            coo_array(
                (np.r_[2 * j + 1, -np.ones(m)], (np.r_[np.arange(m), np.arange(m)], np.r_[i, col[i]])),
                shape=(m, n + chorded.size),
            )
        )
        rows = hstack([csr_array(g_rows[fin]), csr_array((r, chorded.size))])
        a = vstack([rows, chords]).tocsr()
    model = LinearModel(
        np.r_[linear, cost[chorded]],
        a,
        np.full(r + m, -INF),
        np.r_[b[fin], j * (j + 1)],
        np.r_[lo, np.zeros(chorded.size)],
        np.r_[hi, np.full(chorded.size, INF)],
        integer=np.r_[np.ones(n, bool), np.zeros(chorded.size, bool)],
    )
    if proof:
        model.prefer_proof()
    if gap > 0:  # an incumbent is wanted, not a proof
        model.set_gap(gap)
    sol = None
    if start is not None and np.all((start >= lo) & (start <= hi)):
        sol = np.r_[start, start[chorded] ** 2]
    res = model.solve(time_limit, sol)
    res.dual_bound += const
    res.objective += const
    k = None if res.x is None else np.clip(np.rint(res.x[:n]), lo, hi)
    return res, k


def descend(g_rows: Array, b: Array, k: Array, cost: Array, deadline: float) -> Array:
    """Coordinate descent on the grid keeping G k ≤ b: Σ c k² never grows.

    Each move takes the coordinate whose best feasible value (the integer nearest 0 in
    its range with every other coordinate fixed) lowers the norm most; it stops when
    no move helps or at ``deadline`` (``now()``).

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); b : ndarray of shape (r,)
    k : ndarray of shape (n,)
        A grid point with G k ≤ b.
    """
    k = k.copy()
    fin = np.isfinite(b)
    rows = g_rows[fin]
    slack = b[fin] - rows @ k
    if np.any(slack < -1e-7):  # not a feasible point: nothing to descend from
        return k
    slack = np.maximum(slack, 0.0)
    pos, neg = rows > 0, rows < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        while now() < deadline:
            ratio = slack[:, None] / rows  # a move by δ on column i needs δ·G_ji ≤ slack_j
            up = np.floor(np.min(np.where(pos, ratio, np.inf), axis=0) + 1e-9)
            down = np.ceil(np.max(np.where(neg, ratio, -np.inf), axis=0) - 1e-9)
            step = np.clip(-k, down, up)
            step = np.where(np.isfinite(step), step, 0.0)
            gain = cost * (k**2 - (k + step) ** 2)
            i = int(np.argmax(gain))
            if gain[i] <= 0:
                break
            k[i] += step[i]
            slack -= step[i] * rows[:, i]
    return k


def lower_bound_ratio(f_best: float, lower: float) -> float:
    """Certified bound on ‖x‖ / ‖x_least‖ (weighted norms) from f(x) and a lower bound on f."""
    if f_best <= 0:
        return 1.0
    if lower <= 0:
        return np.inf
    return float(np.sqrt(f_best / lower))


def chord_least_norm(
    g_rows: Array,
    g: Array,
    level: float,
    b: Array,
    kmin: Array,
    kmax: Array,
    cost: Array,
    best: Array | None,
    k_cont: Array,
    deadline: float,
    proof: bool = False,
) -> tuple[Array | None, bool, str, float]:
    """Exact least Σ c k² over grid points with t(k) ≥ level, by chords of k² (lazy).

    On integers k² is the upper envelope of the chords (2j+1)|k| − j(j+1), j ≥ 0,
    so "min Σ c s, s_i ≥ chords, G k ≤ b" is exact for integer k.  First as an LP:
    when its optimal vertex is integral and every s_i = k_i², that vertex is the
    optimum (the LP is a relaxation and the vertex is a grid point) — the usual
    case when G is a network-like matrix of ±1 relations.  Otherwise the same model
    as a MILP, started from ``best``.  Chords are added where a solution violates
    s_i ≥ k_i² (:func:`~setupfix.optimize.exact.least_norm.chords.lazy_chords`).  Stops at ``deadline``
    (``now()``).

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); g, b : ndarray of shape (r,)
        Margin rows, and the rounded rows holding every grid point with t(k) ≥ level.
    kmin, kmax, cost : ndarray of shape (n,)
    best : ndarray of shape (n,) or None
        A feasible grid point to start from; k_cont: the continuous least-norm point.

    ``proof``: ``best`` is near-least already, so HiGHS spends no time on improvement
    heuristics (:meth:`~setupfix.optimize.exact.highs.LinearModel.prefer_proof`).

    Returns
    -------
    best : ndarray or None
        Best grid point found with t(k) ≥ level (``best`` if none better).
    proved : bool
    why : str
        Why not proved (``"time limit"`` or HiGHS's words).
    lower : float
        A lower bound on Σ c k² over grid points in the box with t(k) ≥ level (the
        chord model is a relaxation; 0 if no solve finished).
    """
    n = g_rows.shape[1]
    chords: list[set[int]] = []
    ref = np.abs(k_cont) if best is None else np.abs(best)
    for vc, vs in zip(np.abs(k_cont), ref, strict=True):
        base = int(np.floor(vc))
        chords.append({max(base - 1, 0), base, base + 1, int(vs)})
    a_chords, rhs = chord_rows([(i, j) for i, js in enumerate(chords) for j in sorted(js)], n, 2 * n)
    fin = np.isfinite(b)
    a = vstack([hstack([csr_array(g_rows[fin]), csr_array((int(fin.sum()), n))]), a_chords]).tocsr()
    model = LinearModel(
        np.r_[np.zeros(n), cost],
        a,
        np.full(a.shape[0], -INF),
        np.r_[b[fin], rhs],
        np.r_[kmin, np.zeros(n)],
        np.r_[kmax, np.full(n, INF)],
    )
    if proof:
        model.prefer_proof()

    def feasible(k: Array) -> bool:
        return bool(grid_margins(g_rows, g, k) >= level - TOL)

    out = lazy_chords(
        model, n, chords, cost, kmin, kmax, best, feasible, lambda k: np.r_[k, k**2], deadline, integer=False
    )
    return out.best, out.proved, out.why, out.lower


def network_rows(g_rows: Array, b: Array) -> bool:
    """Whether ``G k ≤ b`` is totally unimodular with an integral right side, by a network signing.

    Exact test of a sufficient structure: every row has one or two non-zeros, each ±1, and
    the columns split into two classes such that negating one class leaves every two-entry
    row with one +1 and one −1 (an arc of a directed graph: a network matrix, totally
    unimodular); each finite b_j is an integer.  Then every vertex of
    ``{(k, s): G k ≤ b, box, s_i ≥ chords of k_i² at integers}`` has integral k (at a vertex
    the k off the chords' breakpoints solve a square subsystem of G, unimodular, with an
    integral right side), so the chord LP of :func:`chord_least_norm` ends on the grid
    without a MILP.

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); b : ndarray of shape (r,) (+inf: no row)
    """
    fin = np.isfinite(b)
    if not np.all(np.abs(b[fin] - np.rint(b[fin])) <= 1e-9):
        return False
    r_idx, c_idx = np.nonzero(g_rows)  # one pass over the matrix (row-major: a row's entries are adjacent)
    live = fin[r_idx]
    r_idx, c_idx = r_idx[live], c_idx[live]
    vals = g_rows[r_idx, c_idx]
    if not np.all(np.abs(vals) == 1.0):
        return False
    count = np.bincount(r_idx, minlength=g_rows.shape[0])
    if np.any(count > 2):
        return False
    first = np.cumsum(count) - count  # position of each row's first entry
    two = np.flatnonzero(count == 2)
    if two.size == 0:
        return True
    n = g_rows.shape[1]
    i, j = c_idx[first[two]], c_idx[first[two] + 1]
    differ = (vals[first[two]] == vals[first[two] + 1]).astype(np.intp)
    # same signs: the two columns in different classes; opposite signs: in the same class.  Node
    # (i, c) is "column i in class c"; a row joins (i, c) to (j, c xor differ) for c = 0, 1, and the
    # classes exist iff no column has both its nodes in one component.
    src = np.r_[2 * i, 2 * i + 1]
    dst = np.r_[2 * j + differ, 2 * j + (1 - differ)]
    graph = coo_array((np.ones(src.size), (src, dst)), shape=(2 * n, 2 * n))
    _, label = connected_components(graph, directed=False)
    return bool(np.all(label[0::2] != label[1::2]))
