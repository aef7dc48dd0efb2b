"""Coral reefs inspired particle swarm optimisation (CRIPSO), Stryczek (2014).

A colony of stationary particles (polyps) on the register grid.  Each step two
polyps drawn at random compete on f = 10·f1 − f2 (eq. 10); the loser dies and the
winner's larva (planula) settles in its place at the point given by eq. 1::

    x' = x + w (plast − x) + c1 r1 (pbest − x) + c2 r2 (gbest − x)      (eq. 1)
    c1 = c2 = cos(π/2 · L_i / L)                                        (eq. 11)

Sections of the paper used: "Coral reefs inspired particle swarm optimization"
(Fig. 3 flow, Fig. 4 items I–III, eq. 1), "Formulating the optimization task"
(eqs. 5–10, the bounded discrete decision space) and "Comparison …" (P = 100
polyps, w = 0.75, eq. 11, 5,000 solutions).

Details the paper leaves open, decided here (each with the passage it rests on):

1. **Initial colony.**  ``n_polyps`` points drawn uniformly from the register
   grid inside the bounds.  The decision space is bounded on both sides and
   discrete, one step per register resolution ("Formulating the optimization
   task"); each polyp is one solution (Fig. 3 text).
2. **Tournament.**  Two distinct polyps, uniformly at random; the larger f
   (eq. 10) wins, a tie goes to the first drawn (the draw order is random, so a
   tie is a fair coin).  The loser leaves the colony and the winner's planula
   takes its place (Fig. 3 text: the contest between two random solutions, the
   winner stays, the worse one is removed).
3. **r1, r2 per component.**  Fresh U(0, 1) numbers for every register of every
   planula.  Eq. 1 is stated for the i-th dimension with r1, r2 listed as
   uniform random numbers in [0, 1], and the method is built on PSO as described
   by Poli et al. (2007), which draws them per dimension.
4. **Inertia, plast (Fig. 4 item I).**  plast − x is the shift of the last
   planula the polyp produced.  After spawning, the winner's plast is the
   settlement point x' (its next inertia vector is x' − x).  A new polyp has
   produced nothing yet; item I gives its inertia the direction parent →
   settlement point, and we keep that move's length too: plast_new − x' = x' − x.
   So parent and child carry the same inertia vector.  Initial polyps have
   produced nothing and no parent: plast = x (no inertia) until they first win.
5. **pbest (Fig. 4 item II).**  The best descendant so far, started at the
   polyp's own position (PSO's personal best includes the particle's start, and
   an empty "best descendant" would leave eq. 1 undefined) and replaced when one
   of its planulae scores a strictly larger f.  The new polyp inherits its
   parent's pbest (item II) *after* that update, so it is never worse than the
   child itself.
6. **gbest (Fig. 4 item III).**  The best polyp of the colony.  Because every
   planula settles and only losers die, this is the best solution evaluated so
   far, except that on an exact tie the best polyp may lose; the equal winner
   then becomes gbest.
7. **Eq. 11.**  L_i is the 1-based number of the solution being generated,
   counting the initial colony (the paper's "successive number of a
   solution"), L = ``n_solutions``; the last planula has c1 = c2 = 0.
8. **Grid and bounds.**  Eq. 1 is evaluated in grid units, term by term, and
   the settlement point is snapped to the nearest grid step (``numpy.rint``:
   exactly halfway goes to the even step) and clipped into the bounds, so fixed
   registers (bounds 0, 0) never move.  The paper only says the space is discrete
   at the register resolution.  A side effect worth knowing: w·1 = 0.75 rounds
   back to 1, so a one-step inertia never dies out on the grid and late planulae
   keep probing one step along their parent's last move.
9. **Budget.**  Exactly ``n_solutions`` solutions are evaluated, the initial
   colony included (P + (L − P) planulae, one per tournament).  With
   ``n_solutions < n_polyps`` the colony is just the first ``n_solutions``
   random points.

The tournament is sequential (each planula may change the colony the next one
sees), so the hot loop stays a Python loop: all random numbers are drawn in bulk
beforehand, solutions are written into one preallocated (L, n) array, polyps,
pbest and gbest are row pointers into it, and one candidate costs about twenty
numpy calls on arrays of 10–60 numbers.  The :class:`Evaluator` is fed afterwards with the stored
solutions, cut at every strict improvement, so its count, best solution and
best-so-far history are those of a one-by-one feed.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.core.params import Constraint, Interval
from setupfix.correction.objective import F1_WEIGHT
from setupfix.optimize.base import Evaluator, Metaheuristic
from setupfix.optimize.problem import CorrectionProblem
from setupfix.search import acceleration

__all__ = ["CRIPSO", "coefficient_schedule", "planula_position"]

Array = npt.NDArray[np.float64]


def coefficient_schedule(n_solutions: int) -> Array:
    """Cognition and social coefficients c1 = c2 for every solution number (eq. 11).

    :func:`setupfix.search.acceleration` for L_i = 1 … L.

    Parameters
    ----------
    n_solutions : int
        Total number of solutions L.

    Returns
    -------
    ndarray of shape (L,) [-]
        Entry L_i − 1 holds cos(π/2 · L_i / L): from almost 1 down to 0 for the last solution.
    """
    total = int(n_solutions)
    return acceleration(np.arange(1, total + 1), total)


def planula_position(
    x: Array,
    plast: Array,
    pbest: Array,
    gbest: Array,
    *,
    inertia: float,
    c1: Array | float,
    c2: Array | float,
    r1: Array | float,
    r2: Array | float,
    out: Array | None = None,
) -> Array:
    """Settlement point of a planula before snapping to the grid (eq. 1).

    x' = x + w (plast − x) + c1 r1 (pbest − x) + c2 r2 (gbest − x), evaluated term by
    term from the left (the CRIPSO loop calls it with ``out`` on grid units).

    Parameters
    ----------
    x, plast, pbest, gbest : ndarray of shape (..., n_registers) [any length unit]
        Parent polyp, its last planula, its best descendant and the colony's best.
    inertia : float
        w.
    c1, c2 : float or ndarray broadcastable to (..., n_registers)
        Cognition and social coefficients (eq. 11).
    r1, r2 : float or ndarray broadcastable to (..., n_registers)
        U(0, 1) numbers.
    out : ndarray, optional
        Where to write the result (no allocation for it).

    Returns
    -------
    ndarray of shape (..., n_registers), in the unit of ``x``.
    """
    out = np.multiply(np.subtract(plast, x), inertia, out=out)
    out += x
    out += c1 * r1 * (pbest - x)
    out += c2 * r2 * (gbest - x)
    return out


def _feed(evaluate: Evaluator, problem: CorrectionProblem, x: Array) -> None:
    """Pass solutions x of shape (L, n_registers) to ``evaluate`` in their order.

    The Evaluator logs one history row per call; cutting the sequence right after
    every strict improvement of f makes those rows exactly the best-so-far step
    function of a one-by-one feed, in a few dozen vectorised calls.
    """
    f = np.atleast_1d(problem.evaluate(x)[2])
    before = np.concatenate([[-np.inf], np.maximum.accumulate(f)[:-1]])
    ends = np.union1d(np.flatnonzero(f > before) + 1, [f.size])
    start = 0
    for end in ends.tolist():
        evaluate(x[start:end])
        start = end


class CRIPSO(Metaheuristic):
    """Coral reefs inspired PSO of Stryczek (2014); see the module docstring.

    Parameters
    ----------
    n_polyps : int, default=100
        Colony size P (the paper: 100).
    n_solutions : int, default=5000
        Solutions evaluated, the initial colony included (the paper: 5,000).
    inertia : float, default=0.75
        Inertia weight w of eq. 1 (the paper: 0.75).
    seed : int, optional
        Seed of :func:`numpy.random.default_rng`; the same seed gives the same run.
    """

    name: ClassVar[str] = "cripso"
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        **Metaheuristic._parameter_constraints,
        "n_polyps": [Interval(int, 2, 100_000)],  # a tournament needs two polyps
        "inertia": [Interval(float, 0.0, 2.0)],
    }

    def __init__(
        self, *, n_polyps: int = 100, n_solutions: int = 5000, inertia: float = 0.75, seed: int | None = None
    ) -> None:
        super().__init__(n_solutions=n_solutions, seed=seed)
        self.n_polyps = n_polyps
        self.inertia = inertia

    def _search(self, problem: CorrectionProblem, rng: np.random.Generator, evaluate: Evaluator) -> None:
        total = evaluate.remaining
        colony = min(int(self.n_polyps), total)
        steps = total - colony
        n = problem.n_registers
        h = problem.resolution
        kmin = problem.kmin.astype(float)
        kmax = problem.kmax.astype(float)
        # Work in grid units k (x = h·k).  Margins of eqs. 5–6 as one affine map,
        # margins = base + k @ gain, so one candidate costs one small mat-vec.
        gain = h * np.hstack([problem.composite, -problem.composite])
        base = np.concatenate([problem.deviation - problem.lower, problem.upper - problem.deviation])
        base = np.where(np.isnan(base), np.inf, base)  # absent dimensions do not count (eq. 8)
        w = float(self.inertia)

        # Random numbers in bulk, in this order: colony, tournament pairs, r1 and r2.
        sol = np.empty((total, n))
        sol[:colony] = rng.integers(problem.kmin, problem.kmax + 1, size=(colony, n))
        first = rng.integers(0, colony, steps)
        second = (first + rng.integers(1, colony, steps)) % colony if colony > 1 else first
        r = rng.random((2, steps, n))
        c = coefficient_schedule(total)[colony:].tolist()  # L_i = colony + 1 … L

        start = sol[:colony]
        f0 = F1_WEIGHT * np.min(base + start @ gain, axis=1) - h * np.sqrt(np.einsum("ij,ij->i", start, start))
        fit = f0.tolist()  # f of each polyp
        pos = list(range(colony))  # row of sol where each polyp sits
        best = list(range(colony))  # row of each polyp's pbest
        fbest = list(fit)
        plast = sol[:colony].copy()  # last planula of each polyp, grid units (none yet: plast = x)
        gbest_polyp = int(np.argmax(f0))
        gbest_row = gbest_polyp
        gbest_f = fit[gbest_polyp]
        sqrt = math.sqrt

        for t, (i, j) in enumerate(zip(first.tolist(), second.tolist(), strict=True)):
            win, lose = (i, j) if fit[i] >= fit[j] else (j, i)
            if lose == gbest_polyp:  # only on a tie: the equal winner is the colony's best now
                gbest_polyp, gbest_row = win, pos[win]
            x = sol[pos[win]]
            new = sol[colony + t]
            # Eq. 1 term by term, left to right.  The differences are whole grid steps, so a
            # vanishing term is exactly 0 and a settlement point exactly halfway between two
            # steps (frequent: w·2 = 1.5) is rounded by rint's rule, not by rounding noise.
            planula_position(
                x,
                plast[win],
                sol[best[win]],
                sol[gbest_row],
                inertia=w,
                c1=c[t],
                c2=c[t],
                r1=r[0, t],
                r2=r[1, t],
                out=new,
            )
            np.rint(new, out=new)
            np.maximum(new, kmin, out=new)
            np.minimum(new, kmax, out=new)
            child = plast[lose]
            np.subtract(new, x, out=child)  # child: plast − x' = x' − x (parent → settlement point)
            child += new
            plast[win] = new  # winner: its last planula settled at x'
            f = F1_WEIGHT * float((base + new @ gain).min()) - h * sqrt(float(new @ new))
            pos[lose] = colony + t
            fit[lose] = f
            if f > fbest[win]:
                best[win] = colony + t
                fbest[win] = f
            best[lose] = best[win]
            fbest[lose] = fbest[win]
            if f > gbest_f:
                gbest_polyp, gbest_row, gbest_f = lose, colony + t, f
        # Back to model units.  A bound such as 0.013 is not 13 · 0.001 in floating point, so
        # points on a bound take the bound's own value (what problem.snap gives); nothing is
        # clipped here, so a point the loop let out of bounds would show.
        x = np.where(sol == kmax, problem.ub, np.where(sol == kmin, problem.lb, sol * h))
        _feed(evaluate, problem, x)
