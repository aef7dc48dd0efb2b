"""The leximin order of sorted margins, and a good grid point for the leximin levels by local search.

Grid units as in :mod:`setupfix.optimize.exact.session`.  The leximin levels
(:mod:`setupfix.optimize.exact.leximin.levels`) prove each level at a grid point's own level; the proof is
one NNLS when the point already reaches the level, and an ascent (roundings, LPs, MILPs) when it
does not.  Started from the paper's optimum, the levels spent most of their time climbing.
:func:`climb` climbs first, on the grid itself: from k it moves to the neighbour whose sorted
margins of the active dimensions are lexicographically largest (the fixed ones kept at their
floors), among the moves ``s·e_i`` and ``s·(±e_i ± e_j)`` — one register, or two that share a
row (a WKS and a tool that must move together to keep a dimension) — with the step s from
:data:`SCALES` (the solver's: ``ExactSettings.climb_scales``) down to 1 as the climbs stop.  How
often it reaches a leximin-optimal point is measured by ``bench/leximin_speed.py``; where it does
not, the levels climb on from its point.

The climb is a heuristic and takes no decision: the levels use its point only where its own
level is higher than theirs (:meth:`~setupfix.optimize.exact.leximin.level.LevelModel.level_of`), and
prove every level as before (``tests/optimize/test_leximin_search.py``: the same answers with and
without it).  Written here, not taken from a library's local search, because the order is leximin
over grouped rows with ties within ε, evaluated for a whole neighbourhood at once in numpy.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.work import now

__all__ = ["SCALES", "Moves", "climb", "climb_moves", "group_min", "lex_order", "two_rows_each"]

Array = npt.NDArray[np.float64]

#: Steps of the moves, largest first [steps]; each scale climbs until no move improves (the default of
#: :func:`climb`; the solver passes ``ExactSettings.climb_scales``, the same by default).
SCALES = (4.0, 1.0)


def lex_order(a: Array, b: Array, eps: float) -> int:
    """+1 if sorted margins a beat sorted b in the leximin order (ties within ε), −1 if below, 0 if tied
    (over the shorter one's length: a branch's settled margins against the best branch's start)."""
    for x, y in zip(a, b, strict=False):
        if abs(x - y) > eps:
            return 1 if x > y else -1
    return 0


Moves = tuple[Array, Array, Array, Array]


def climb_moves(g_rows: Array, order: npt.NDArray[np.intp]) -> Moves:
    """The moves of :func:`climb` and their change of G k (rows in ``order``), from G alone.

    Returns
    -------
    single : ndarray of shape (2n, n)
        One-register moves ±e_i.
    double : ndarray of shape (4p, n)
        Two-register moves ±e_i ± e_j for registers i < j that share a row (two registers with
        no row in common move as two single moves).
    d_single, d_double : ndarray of shape (2n, r), (4p, r)
        G_j times each move, rows grouped by dimension (``order``).
    """
    n = g_rows.shape[1]
    nz = (g_rows != 0).astype(float)
    i, j = np.nonzero(np.triu(nz.T @ nz, 1))
    eye = np.eye(n)
    pairs = [si * eye[i] + sj * eye[j] for si in (1.0, -1.0) for sj in (1.0, -1.0)]
    single, double = np.vstack([eye, -eye]), np.vstack(pairs)
    grouped = g_rows[order]
    out = (single, double, single @ grouped.T, double @ grouped.T)
    for a in out:
        a.flags.writeable = False
    return out


def two_rows_each(starts: npt.NDArray[np.intp], n_rows: int) -> bool:
    """Whether the groups starting at ``starts`` are n_rows / 2 groups of two rows (:func:`group_min`)."""
    return 2 * starts.size == n_rows and bool(np.all(starts == np.arange(0, n_rows, 2)))


def group_min(m: Array, starts: npt.NDArray[np.intp], pairs: bool | None = None) -> Array:
    """Row margins (c, r), rows grouped by dimension (groups start at ``starts``) → each group's least,
    shape (c, n_groups).  Groups of two rows each (a one-axis problem: every dimension's two limits;
    ``pairs``: :func:`two_rows_each`, when the caller knows it) by two strided views —
    ``np.minimum.reduceat`` along the second axis costs some ten times more."""
    if two_rows_each(starts, m.shape[1]) if pairs is None else pairs:
        return np.minimum(m[:, 0::2], m[:, 1::2])
    return np.minimum.reduceat(m, starts, axis=1)


def _sorted_margins(
    m: Array,
    starts: npt.NDArray[np.intp],
    active: npt.NDArray[np.intp],
    fixed: npt.NDArray[np.intp],
    floors: Array,
    pairs: bool | None = None,
) -> Array:
    """Row margins (c, r), rows grouped by dimension (groups start at ``starts``) → each point's margins
    of the groups ``active``, sorted ascending — shape (c, n_active); a point with a group ``fixed``
    below its floor (``floors``, one per fixed group) gets −inf throughout (never better)."""
    by_dim = group_min(m, starts, pairs)
    out = np.sort(by_dim if active.size == by_dim.shape[1] else by_dim[:, active], axis=1)
    if fixed.size:
        out[np.any(by_dim[:, fixed] < floors, axis=1)] = -np.inf
    return out


def climb(
    g_rows: Array,
    g: Array,
    k: Array,
    kmin: Array,
    kmax: Array,
    order: npt.NDArray[np.intp],
    starts: npt.NDArray[np.intp],
    floors: Array,
    eps: float,
    deadline: float = np.inf,
    moves: Moves | None = None,
    scales: tuple[float, ...] = SCALES,
) -> Array:
    """A grid point at least as good as k in the leximin order of the active dimensions.

    Parameters
    ----------
    g_rows : ndarray of shape (r, n); g : ndarray of shape (r,)
        Rows in grid units (margin of row j at k: g_j − G_j k).
    k : ndarray of shape (n,)
        The start, on the grid and in the box [kmin, kmax].
    order, starts : ndarray of int
        The rows grouped by dimension (``order``) and where each group starts (for ``np.minimum.reduceat``).
    floors : ndarray of shape (n_groups,)
        Per group: NaN (active: in the order), else its floor [steps] (fixed: a point with its margin
        below the floor is never taken; −inf: left out).
    eps : float
        Margins within ε are ties [steps].
    deadline : float, optional
        ``now()`` at which the climb stops where it is (the solve's limit).
    moves : tuple of ndarray, optional
        :func:`climb_moves` of (g_rows, order), when the caller keeps them (one model, many reports).
    scales : tuple of float, optional
        Steps of the moves, largest first [steps] (default :data:`SCALES`).

    Returns
    -------
    ndarray of shape (n,)
        The last point of the climb (k itself when no neighbour is better).
    """
    if k.size == 0 or not np.isnan(floors).any():
        return k
    single, double, d_single, d_double = climb_moves(g_rows, order) if moves is None else moves
    g_rows, g = g_rows[order], g[order]  # rows grouped by dimension
    m_k = g - g_rows @ k
    active, fixed = np.flatnonzero(np.isnan(floors)), np.flatnonzero(np.isfinite(floors))
    below = floors[fixed] - 1e-9
    pairs = two_rows_each(starts, g_rows.shape[0])
    cur = _sorted_margins(m_k[None, :], starts, active, fixed, below, pairs)[0]
    for s in scales:
        moved = True
        scaled = ((single, s * d_single), (double, s * d_double))
        while moved and now() < deadline:
            moved = False
            for dirs, d_rows in scaled:
                m = m_k - d_rows
                sm = _sorted_margins(m, starts, active, fixed, below, pairs)
                diff = sm - cur
                # better: the first margin that differs by more than ε is higher (no such margin: argmax is 0, a tie)
                first = np.argmax(np.abs(diff) > eps, axis=1)
                up = np.flatnonzero(diff[np.arange(first.size), first] > eps)
                if up.size:  # the box is checked for the better points only (it rarely binds)
                    cand = k + s * dirs[up]
                    if min(float((k - kmin).min()), float((kmax - k).min())) < s:  # a move of s can leave it
                        inside = np.all((cand >= kmin) & (cand <= kmax), axis=1)
                        up, cand = up[inside], cand[inside]
                if up.size:
                    best = 0 if up.size == 1 else int(np.lexsort(np.round(sm[up], 6).T[::-1])[-1])
                    k, m_k, cur = cand[best], m[up[best]], sm[up[best]]
                    moved = True
                    break
    return k
