"""The outcome of the leximin levels, and the least norm among its leximin-optimal grid points.

Grid units as in :mod:`setupfix.optimize.exact.session`.  The levels (:mod:`setupfix.optimize.exact.leximin.levels`)
end with a floor v_q for every dimension, or with count blocks where a discrete conflict was left
to the counts (:mod:`setupfix.optimize.exact.leximin.counts`), or with tied branches of a conflict
(``alternatives``).  The leximin-optimal points are then the grid points with M_q ≥ v_q for every
q (or meeting the blocks), and the answer is the least Σ c k² among them over every alternative
(eq. 9), ties to the lexicographically smallest k.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.grid import TOL
from setupfix.optimize.exact.least_norm.grid import LeastNorm, grid_least_norm
from setupfix.optimize.exact.leximin.counts import CountLevels, count_least_norm
from setupfix.optimize.exact.session import GridRows, Session
from setupfix.optimize.problem import Stopped

__all__ = ["Leximin", "leximin_least_norm", "leximin_vector", "levels_of"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Leximin:
    """Outcome of the leximin levels (before the least norm).

    Attributes
    ----------
    k : ndarray of shape (n,)
        A leximin-optimal grid point (the best found when ``stopped``).
    floors : ndarray of shape (n_dims,)
        v_q [steps]: the floor of each dimension (−inf for a dimension without rows).
    levels : tuple of (float, int)
        The leximin vector as distinct values [steps] and how many dimensions sit at each.
    counts : CountLevels or None
        The count constraints that decide the dimensions left when a discrete conflict
        stopped the progressive filling (None: every dimension has its floor).
    stopped : Stopped or None
    path : tuple of str
    calls : int
        Solver calls.
    alternatives : tuple of Leximin
        Other outcomes with the same leximin vector (branches of a discrete conflict that tie).
    """

    k: Array
    floors: Array
    levels: tuple[tuple[float, int], ...]
    counts: CountLevels | None
    stopped: Stopped | None
    path: tuple[str, ...]
    calls: int
    alternatives: tuple[Leximin, ...] = ()


def leximin_vector(lex: Leximin) -> Array:
    """The sorted margins the outcome's levels stand for (each value repeated by its count)."""
    return np.repeat([a for a, _ in lex.levels], [b for _, b in lex.levels])


def levels_of(v: Array) -> tuple[tuple[float, int], ...]:
    """The leximin vector as (value, count): every finite floor counted once at its value."""
    finite = v[np.isfinite(v)]
    values, counts = np.unique(np.round(finite, 9), return_counts=True)
    return tuple((float(a), int(b)) for a, b in zip(values, counts, strict=True))


def leximin_least_norm(session: Session, lex: Leximin, row_dim: npt.NDArray[np.intp], box_share: float) -> LeastNorm:
    """The least Σ c k² among the leximin-optimal grid points (every margin at least its floor).

    Floors for every dimension: stage 3 on the rows shifted by them (g_j − v_q(j) ≥ G_j k, level 0).
    Count constraints left by a discrete conflict: :func:`~setupfix.optimize.exact.leximin.counts.count_least_norm`.
    Tied branches (``lex.alternatives``): the least over them (ties: the lexicographically smallest k).
    """
    best: LeastNorm | None = None
    for option in (lex, *lex.alternatives):
        least = _least_norm_of(session, option, row_dim, box_share)
        if best is None or _better(least, best, session.rows.cost):
            best = (
                least
                if best is None
                else LeastNorm(
                    least.k,
                    least.proved and best.proved,
                    least.why or best.why,
                    min(least.lower, best.lower),
                    best.path + least.path,
                )
            )
        else:
            best = LeastNorm(
                best.k,
                least.proved and best.proved,
                best.why or least.why,
                min(least.lower, best.lower),
                best.path + least.path,
            )
    assert best is not None
    return best


def _better(a: LeastNorm, b: LeastNorm, cost: Array) -> bool:
    fa, fb = float(np.sum(cost * a.k**2)), float(np.sum(cost * b.k**2))
    if abs(fa - fb) > 1e-9 * max(1.0, fb):
        return fa < fb
    return tuple(a.k) < tuple(b.k)


def _least_norm_of(session: Session, lex: Leximin, row_dim: npt.NDArray[np.intp], box_share: float) -> LeastNorm:
    rows = session.rows
    if lex.counts is not None:
        return count_least_norm(session, row_dim, lex.counts, lex.k)
    floor_rows = lex.floors[row_dim]
    g_shift = np.where(np.isfinite(floor_rows), rows.g - floor_rows, np.inf)
    shifted = Session(
        GridRows(rows.g_rows, g_shift, rows.kmin, rows.kmax, rows.cost),
        session.settings,
        session.time_limit,
        session.clock,
    )
    b = shifted.rows.rounded(0.0)
    b[~np.isfinite(g_shift)] = np.inf
    return grid_least_norm(shifted, -TOL, b, lex.k, None, None, box_share)
