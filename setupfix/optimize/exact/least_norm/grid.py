"""Stage 3 of the exact solve: the least Σ c_i k_i² (eq. 9) among grid points with t(k) ≥ t*.

Grid units as in :mod:`setupfix.optimize.exact.session`; b are the rows rounded at t*, which
hold every such grid point.  In order, each step stopping as soon as it proves:

1. the continuous least norm over b (NNLS, or HiGHS's QP) gives a point κ₀ and
   multipliers λ; the Lagrangian bound f(k) ≥ Σ c_i (k_i − κ_i)² + q holds for every
   feasible k (:func:`~setupfix.optimize.exact.least_norm.listing.lagrangian_ball`);
2. small problems: the integer points of that ellipsoid which could beat the best known
   point are listed exhaustively — the least feasible one is the grid least norm;
3. a near-least incumbent: heuristics, then the least norm in the unit box around the
   rounded continuous point (one MILP; one step wider if that box is empty);
4. the box that the same multipliers prove holds every point at most as large as the
   incumbent (:func:`~setupfix.optimize.exact.least_norm.shop.lagrangian_box`): one MILP with all
   its chords when small, else chords added lazily (:func:`chord_proof`);
5. if the limit stops the proof: coordinate descent on the best point, and a certified
   lower bound on the norm (:func:`~setupfix.optimize.exact.least_norm.shop.lower_bound_ratio`).

Between steps 2 and 3, where the rows are a network matrix after flipping some columns (one
WKS and one tool per dimension; :func:`~setupfix.optimize.exact.least_norm.shop.network_rows`), the
chord LP's vertex is on the grid: one LP (chords added lazily) proves the least norm before
any MILP.

Ties: whichever step proves the least norm F, the grid points of norm F are listed in the
dual ellipsoid (at most :data:`TIE_WORK` array elements, up to :data:`TIE_MAX_REGISTERS`
registers) and the lexicographically smallest is the answer; where they are too many to list,
the path says the tie is not broken.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.grid import TOL, grid_margins
from setupfix.optimize.exact.least_norm.listing import ellipsoid_search, lagrangian_ball
from setupfix.optimize.exact.least_norm.shop import (
    box_least_norm,
    chord_least_norm,
    descend,
    lagrangian_box,
    network_rows,
)
from setupfix.optimize.exact.session import Relaxation, Session
from setupfix.optimize.exact.work import now

__all__ = ["TIE_MAX_REGISTERS", "TIE_WORK", "LeastNorm", "chord_proof", "grid_least_norm"]

Array = npt.NDArray[np.float64]

#: Array elements the listing of the least norm's ties may touch (≈ 20 ms; beyond, the tie is kept
#: as the proof found it and the path says so).
TIE_WORK = 400_000
#: Registers beyond which the ties are not listed (as ``ellipsoid_max_registers``).
TIE_MAX_REGISTERS = 120


@dataclass(frozen=True)
class LeastNorm:
    """Outcome of stage 3.

    Attributes
    ----------
    k : ndarray of shape (n,)
        The correction [steps]; t(k) ≥ t*.
    proved : bool
        k is the least Σ c k² among such grid points (ties: the lexicographically smallest
        when proved by listing).
    why : str
        Why not proved (empty when proved).
    lower : float
        Certified lower bound on the least Σ c k² (0 when none is known).
    path : tuple of str
        The steps taken, for ``result.path``.
    """

    k: Array
    proved: bool
    why: str
    lower: float
    path: tuple[str, ...]


def _ceil_bound(lower: float, cost: Array) -> float:
    """A lower bound on Σ c k² over integers, rounded up to an integer when every cost is one."""
    if np.all(cost == np.rint(cost)):
        return float(np.ceil(lower - 1e-6))
    return lower - 1e-9 * max(1.0, abs(lower))


def chord_proof(
    session: Session,
    t_star: float,
    b: Array,
    lo: Array,
    hi: Array,
    best: Array | None,
    k_cont: Array,
    time_limit: float,
    proof: bool = False,
) -> tuple[Array | None, bool, str, float]:
    """:func:`~setupfix.optimize.exact.least_norm.shop.chord_least_norm` in the box [lo, hi].

    It runs for at most ``time_limit`` s.
    """
    rows = session.rows
    deadline = min(session.clock.deadline, now() + max(time_limit, 0.0))
    return chord_least_norm(rows.g_rows, rows.g, t_star, b, lo, hi, rows.cost, best, k_cont, deadline, proof)


def _good_incumbent(session: Session, t_star: float, b: Array, best: Array, relaxation: Relaxation | None) -> Array:
    """A small feasible grid point before the MILPs (heuristics; the MILPs prove or improve it).

    * Safe rounding: the continuous least-norm point of the rows tightened by half their
      l1 norm rounds to a point that meets the original rows (each coordinate moves ≤ ½).
    * The segment from the incumbent to the continuous least-norm point is feasible; the
      rounded point farthest along it that stays feasible.
    * :func:`~setupfix.optimize.exact.least_norm.shop.descend`: coordinate moves towards 0 while feasible.
    """
    rows = session.rows

    def f(k: Array) -> float:
        return float(np.sum(rows.cost * k**2))

    def ok(k: Array) -> bool:
        return bool(grid_margins(rows.g_rows, rows.g, k) >= t_star - TOL)

    if session.small:  # one more QP only where QPs are cheap
        _, safe = session.least_norm(b - 0.5 * np.sum(np.abs(rows.g_rows), axis=1))
        if safe is not None:
            k = np.clip(np.rint(safe.k), rows.kmin, rows.kmax)
            if ok(k) and f(k) < f(best):
                best = k
    if relaxation is not None:
        lo, hi = 0.0, 1.0
        for _ in range(12):
            mid = (lo + hi) / 2
            k = np.clip(np.rint(best + mid * (relaxation.k - best)), rows.kmin, rows.kmax)
            if ok(k):
                lo = mid
                if f(k) < f(best):
                    best = k
            else:
                hi = mid
    return descend(rows.g_rows, b, best, rows.cost, now() + 0.03 * max(session.clock.left(), 0.0))


def _smallest_tie(
    session: Session, t_star: float, b: Array, best: Array, relaxation: Relaxation | None
) -> tuple[Array, bool]:
    """The lexicographically smallest grid point with t(k) ≥ t_star of norm f(best), f(best) proven least.

    Lists the grid points of norm ≤ f(best) in the dual ellipsoid (every one lies in it), within
    the listing's work limits and up to :data:`TIE_MAX_REGISTERS` registers (beyond, the list
    never closed in ``bench/least_norm_tu.py`` and cost some 60 ms at 180 × 2,000); False when
    the list would be too long (``best`` is returned).
    """
    rows, s = session.rows, session.settings
    if rows.kmin.size > TIE_MAX_REGISTERS:  # the ellipsoid holds too many grid points to list
        return best, False
    fin = np.isfinite(b)
    if relaxation is not None:
        centre, q = lagrangian_ball(
            rows.g_rows[fin],
            b[fin],
            rows.kmin,
            rows.kmax,
            rows.cost,
            relaxation.lam_rows[fin],
            relaxation.lam_lo,
            relaxation.lam_hi,
        )
        multipliers = relaxation.multipliers()
    else:  # no multipliers: the ball f(k) ≤ f(best) itself
        centre, q, multipliers = np.zeros(rows.kmin.size), 0.0, None
    found, proved, _ = ellipsoid_search(
        rows.g_rows,
        rows.g,
        t_star,
        centre,
        q,
        rows.cost,
        rows.kmin,
        rows.kmax,
        float(np.sum(rows.cost * best**2)),
        s.enumeration_limit,
        b,
        work_limit=min(s.enumeration_work, TIE_WORK),
        multipliers=multipliers,
    )
    return (best if found is None else found), proved


def grid_least_norm(
    session: Session,
    t_star: float,
    b: Array,
    incumbent: Array,
    relaxation: Relaxation | None,
    unit_box: bool | None,
    box_share: float,
) -> LeastNorm:
    """Least Σ c k² over grid points with every margin ≥ t_star (steps 1–5 of the module text).

    ``relaxation``: the continuous least norm over ``b``, if known.  ``unit_box``: the
    grid-optimum stage searched the unit box around it already (True: the incumbent is its
    point; False: it is empty).  ``box_share``: share of the time left for each box MILP.
    """
    rows, s, clock = session.rows, session.settings, session.clock
    g_rows, g, kmin, kmax, cost = rows.g_rows, rows.g, rows.kmin, rows.kmax, rows.cost
    reserve = s.descent_reserve * session.time_limit
    path: list[str] = []

    def norm(k: Array) -> float:
        return float(np.sum(cost * k**2))

    def ok(k: Array | None) -> bool:
        return k is not None and bool(grid_margins(g_rows, g, k) >= t_star - TOL)

    def finish(best: Array, proved: bool, why: str, lower: float) -> LeastNorm:
        if not proved:  # coordinate descent on the best point (the norm never grows)
            best = descend(g_rows, b, best, cost, now() + max(clock.left(), 0.0) + reserve / 2)
        return LeastNorm(best, proved, why, lower, tuple(path))

    def proven(best: Array) -> LeastNorm:  # the least norm is proved: ties to the smallest correction
        best, listed = _smallest_tie(session, t_star, b, best, relaxation)
        if not listed:
            path.append("least norm: too many grid points of the least norm to list; the tie is not broken")
        return LeastNorm(best, True, "", norm(best), tuple(path))

    def network_lp(best: Array) -> LeastNorm | None:  # rows of a network matrix: one chord LP proves it
        if not (
            session.settings.network_lp
            and np.all(kmin == np.rint(kmin))
            and np.all(kmax == np.rint(kmax))
            and network_rows(g_rows, b)
        ):
            return None
        k_cont = best if relaxation is None else relaxation.k
        found, proved, _, _ = chord_proof(
            session, t_star, b, kmin, kmax, best, k_cont, time_limit=clock.left() - reserve
        )
        if proved and found is not None:
            path.append("least norm: one LP over the chords of k² (network rows: its vertex is on the grid)")
            return proven(found)
        path.append("least norm: the network rows' chord LP did not prove it")
        return None

    best = incumbent
    if relaxation is None:
        _, relaxation = session.least_norm(b)
    if relaxation is None and (out := network_lp(best)) is not None:
        return out
    if relaxation is None:  # no multipliers: the chord MILP over the whole box
        best = _good_incumbent(session, t_star, b, best, None)
        path.append("least norm: chords of k² (LP, then MILP)")
        found, proved, why, lower = chord_proof(
            session, t_star, b, kmin, kmax, best, best, time_limit=clock.left() - reserve
        )
        if proved and found is not None:
            return proven(found)
        return finish(best if found is None else found, proved, why, lower)
    rounded = np.clip(np.rint(relaxation.k), kmin, kmax)
    if ok(rounded) and norm(rounded) < norm(best):
        best = rounded
    fin = np.isfinite(b)
    centre, q = lagrangian_ball(
        g_rows[fin], b[fin], kmin, kmax, cost, relaxation.lam_rows[fin], relaxation.lam_lo, relaxation.lam_hi
    )
    # A short list only: most reports end here, and where the list would be long the box MILPs
    # below are cheaper (bench/exact_per_report.py).
    if kmin.size <= s.ellipsoid_max_registers:  # beyond, the ellipsoid holds too many grid points
        found, proved, listed = ellipsoid_search(
            g_rows,
            g,
            t_star,
            centre,
            q,
            cost,
            kmin,
            kmax,
            norm(best),
            s.enumeration_limit,
            b,
            work_limit=s.enumeration_work,
            multipliers=relaxation.multipliers(),
        )
        best = best if found is None else found
        if proved:  # the list holds every tie: the pick is the smallest
            path.append(f"least norm: {listed} grid points in the dual ellipsoid")
            return LeastNorm(best, True, "", norm(best), tuple(path))
    # network rows: one LP before any MILP (after the short list, which is cheaper where it closes:
    # bench/least_norm_tu.py)
    if (out := network_lp(best)) is not None:
        return out
    best = _good_incumbent(session, t_star, b, best, relaxation)
    # A near-least incumbent: the least norm in the unit box around the continuous point (a MILP
    # with a linear objective), else in the box one step wider (unless stage 2 settled the unit box).
    floor_c, ceil_c = np.clip(np.floor(relaxation.k), kmin, kmax), np.clip(np.ceil(relaxation.k), kmin, kmax)
    for widen in () if unit_box else (1.0,) if unit_box is False else (0.0, 1.0):
        lo, hi = np.maximum(floor_c - widen, kmin), np.minimum(ceil_c + widen, kmax)
        res, k = box_least_norm(g_rows, b, lo, hi, cost, box_share * clock.left(), best, gap=s.incumbent_gap)
        if k is not None and ok(k) and norm(k) < norm(best):
            best = k
        path.append(f"least norm: box MILP ±{widen:g} around the continuous point ({res.status})")
        if k is not None or res.status not in ("infeasible", "optimal") or clock.left() <= 0:
            break
    box_lo, box_hi, lower = lagrangian_box(centre, q, cost, kmin, kmax, norm(best))
    if norm(best) <= _ceil_bound(lower, cost):
        path.append("least norm: the incumbent meets the Lagrangian bound")
        return proven(best)
    values = f"{np.mean(box_hi - box_lo + 1):.1f} values per register"
    if kmin.size <= s.box_proof_max_registers and float(np.sum(box_hi - box_lo)) <= s.box_proof_max_chords:
        # few registers and a short box: every chord of the box at once, one MILP
        res, found = box_least_norm(g_rows, b, box_lo, box_hi, cost, clock.left() - reserve, best, proof=True)
        path.append(f"least norm: box MILP in the Lagrangian box ({values}; {res.status})")
        found = found if ok(found) else None
        proved = res.status == "optimal" and found is not None
        why = "" if proved else ("time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
        chord_lower = res.dual_bound if np.isfinite(res.dual_bound) else 0.0
    else:
        path.append(f"least norm: chords of k² in the Lagrangian box ({values})")
        found, proved, why, chord_lower = chord_proof(
            session, t_star, b, box_lo, box_hi, best, relaxation.k, time_limit=clock.left() - reserve, proof=True
        )
    if found is not None and norm(found) <= norm(best):
        best = found
    if proved:
        return proven(best)
    # points outside the box have Σ c k² > f(best): the chord bound holds up to f(best)
    return finish(best, proved, why, max(lower, min(chord_lower, norm(best))))
