"""The least norm Σ c_i k_i² (eq. 9) on integers as a linear MILP: chords of k², added lazily.

On the integers, k² is exactly the upper envelope of its chords through consecutive
integers j and j + 1:

    k² = max_{j ≥ 0} (2j+1)·|k| − j(j+1)        (k integer),

so with an epigraph column s_i per register, "min Σ c_i s_i subject to
s_i ≥ ±(2j+1)·k_i − j(j+1)" is the least norm once enough chords are present.  Only
a few are needed: :func:`lazy_chords` solves with the chords known, adds the chord at
|k_i| wherever a solution has s_i < k_i², and repeats; when no s_i is short, the
solution's norm is its objective, so it is least.  This one loop serves the chord
least-norm proof (:func:`~setupfix.optimize.exact.least_norm.shop.chord_least_norm`, in the
Lagrangian box or the whole box) and the triage's third MILP
(:func:`~setupfix.optimize.exact.triage.solve.triage`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_array, csr_array

from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.work import now

__all__ = ["ROOT_LP_MULTIPLE", "ChordProof", "chord_rows", "lazy_chords", "smallest_tie"]

Array = npt.NDArray[np.float64]

#: HiGHS looks at its clock only between the cut rounds of a MILP's root node, each some LP solves
#: long, and overran short limits by seconds at shop scale: a chord MILP starts only when this many
#: times the longest LP of its model is left (else the proof stops at the limit with its incumbent).
ROOT_LP_MULTIPLE = 8.0


def chord_rows(pairs: list[tuple[int, int]], n: int, width: int) -> tuple[csr_array, Array]:
    """Chord cuts of k² on the integers: ``s_i ≥ (2j+1)·|k_i| − j(j+1)`` for each (i, j).

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


@dataclass(frozen=True)
class ChordProof:
    """Outcome of :func:`lazy_chords`.

    Attributes
    ----------
    best : ndarray of shape (n,) or None
        Least-norm feasible grid point found (the one given if none better).
    proved : bool
        ``best`` is the least norm over the model's feasible set.
    why : str
        Why not proved: ``"time limit"`` or ``"HiGHS: <its words>"`` (empty when proved).
    lower : float
        A certified lower bound on Σ c k² over the model's integer points (the chord model is
        a relaxation of the least norm; 0 when no solve finished).
    """

    best: Array | None
    proved: bool
    why: str
    lower: float


def lazy_chords(
    model: LinearModel,
    n: int,
    chords: list[set[int]],
    cost: Array,
    kmin: Array,
    kmax: Array,
    best: Array | None,
    feasible: Callable[[Array], bool],
    start: Callable[[Array], Array],
    deadline: float,
    integer: bool,
) -> ChordProof:
    """Solve ``model`` adding chords of k² where a solution needs them, until none is short.

    Parameters
    ----------
    model : LinearModel
        min Σ c_i s_i (plus zero-cost columns) with the chords ``chords`` already in it;
        columns 0…n−1 are k, n…2n−1 are s (:func:`chord_rows`).
    n : int
        Number of registers.
    chords : list of set of int, length n
        The chords j present per register (updated in place as chords are added).
    cost, kmin, kmax : ndarray of shape (n,)
    best : ndarray of shape (n,) or None
        A feasible grid point to start from.
    feasible : callable
        Whether a rounded solution k (shape (n,)) meets the problem's own conditions (the
        model is solved to HiGHS's tolerances; this check is exact).
    start : callable
        The model's full start vector for a grid point k (k, k², any other columns).
    deadline : float
        ``now()`` value at which to stop.
    integer : bool
        The model is a MILP already.  False: solve it as an LP first — when its vertex is
        integral with every s_i = k_i², that vertex is the optimum (the usual case when G is
        a network-like matrix of ±1 relations); when the LP's fractional coordinates have
        all their chords, the k columns are made integer.
    """
    f_best = np.inf if best is None else float(np.sum(cost * best**2))
    lower = 0.0
    lp_seconds = 0.0
    width = model.n_cols
    while True:
        left = deadline - now()
        if left <= 0 or (integer and left < ROOT_LP_MULTIPLE * lp_seconds):
            return ChordProof(best, False, "time limit", lower)
        started = now()
        res = model.solve(left, None if best is None else start(best))
        if not integer:
            lp_seconds = max(lp_seconds, now() - started)
        bound_k = res.dual_bound if integer else (res.objective if res.status == "optimal" else np.nan)
        if np.isfinite(bound_k):
            lower = max(lower, float(bound_k))
        if res.x is None or res.status not in ("optimal", "time_limit"):
            why = "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}"
            return ChordProof(best, False, why, lower)
        k_raw, s = res.x[:n], res.x[n : 2 * n]
        k = np.clip(np.rint(k_raw), kmin, kmax)
        f_k = float(np.sum(cost * k**2))
        ok = feasible(k)
        if ok and f_k < f_best:
            best, f_best = k, f_k
        if res.status != "optimal":
            return ChordProof(best, False, "time limit", lower)
        fractional = np.flatnonzero(np.abs(k_raw - k) > 1e-7)
        if not integer and fractional.size:
            new = [
                (int(i), int(np.floor(abs(k_raw[i]))))
                for i in fractional
                if int(np.floor(abs(k_raw[i]))) not in chords[i]
            ]
            if not new:
                model.make_integer(np.arange(n))
                integer = True
                continue
        else:
            short = np.flatnonzero(s < k**2 - 1e-6)
            if short.size == 0:
                return ChordProof(best, bool(ok and best is not None and f_best <= f_k), "", lower)
            new = [(int(i), int(abs(k[i]))) for i in short]
        for i, j in new:
            chords[i].add(j)
        a_new, rhs_new = chord_rows(new, n, width)
        model.add_rows(a_new, np.full(rhs_new.size, -INF), rhs_new)


def smallest_tie(
    model: LinearModel,
    n: int,
    chords: list[set[int]],
    cost: Array,
    best: Array,
    feasible: Callable[[Array], bool],
    start: Callable[[Array], Array],
    deadline: float,
) -> tuple[Array, bool]:
    """The lexicographically smallest grid point of ``model`` with Σ c k² ≤ f(best), f(best) proven least.

    One coordinate at a time: min k_i subject to the model, Σ c_i s_i ≤ f(best) and the coordinates
    before i fixed at their values.  The chords make the model a relaxation of "Σ c k² ≤ f(best)"
    (s_i ≥ every chord, each ≤ k_i² on the integers), so its minimum is at most the true one; a
    solution with no s_i short of k_i² (else its chords are added and it is solved again) meets
    Σ c k² ≤ f(best) and so attains it.  Changes ``model`` (row, costs, bounds) and ``chords``.

    Returns the point and whether every coordinate was decided (False: the limit or HiGHS stopped it,
    ``best`` or the smallest point found so far is returned — it has the least norm either way).
    """
    width = model.n_cols
    f = float(np.sum(cost * best**2))
    row = np.zeros((1, width))
    row[0, n : 2 * n] = cost
    model.add_rows(row, np.array([-INF]), np.array([f + 1e-9 * max(1.0, f)]))
    cols = np.arange(width, dtype=np.int32)
    cur = np.asarray(best, dtype=float).copy()
    for i in range(n):
        objective = np.zeros(width)
        objective[i] = 1.0
        model.set_costs(cols, objective)
        while True:
            left = deadline - now()
            if left <= 0:
                return cur, False
            res = model.solve(left, start(cur))
            if res.status != "optimal" or res.x is None:
                return cur, False
            k = np.rint(res.x[:n])
            short = np.flatnonzero(res.x[n : 2 * n] < k**2 - 1e-6)
            if short.size == 0:
                break
            new = [(int(j), int(abs(k[j]))) for j in short]
            for j, c in new:
                chords[j].add(c)
            a_new, rhs_new = chord_rows(new, n, width)
            model.add_rows(a_new, np.full(rhs_new.size, -INF), rhs_new)
        if not feasible(k) or float(np.sum(cost * k**2)) > f + 1e-9 * max(1.0, f) or k[i] > cur[i]:
            return cur, False  # HiGHS's point fails the exact check: keep the proven point
        cur = k
        model.set_col_bounds(np.array([i], dtype=np.int32), cur[i : i + 1], cur[i : i + 1])
    return cur, True
