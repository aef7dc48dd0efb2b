"""Exact optimum of the setup-correction problem with HiGHS (highspy).

The max–min objective f1 (eq. 8) is linear in the corrections, so the problem is a
linear programme, and on the register grid a mixed-integer one.  Everything is
solved in grid units (k = x / resolution, margins in resolution steps), which
keeps the numbers near 1–100 where the solver's tolerances are meaningful.

Input quantum
-------------
Deviations are rounded to 1/1000 of the register resolution (1 nm on a 0.001 mm grid;
``ExactSettings.quantum``) before anything is solved, so the answer does not depend on the last bits
of the input: a report read from CSV and the same numbers computed in memory
(``24.9691 − 25`` against ``-0.0309``) give the same corrections.  Limits are
taken as the model states them.  Reported margins use the unrounded deviations.

Stages, and the proofs that let one be skipped
----------------------------------------------
Each stage is a function of the solve's :class:`~setupfix.optimize.exact.session.Session` that
returns a frozen result: :func:`~setupfix.optimize.exact.lp_bound.lp_bound` →
:class:`~setupfix.optimize.exact.lp_bound.LPBound`, :func:`~setupfix.optimize.exact.grid_optimum.grid_optimum`
→ :class:`~setupfix.optimize.exact.grid_optimum.GridOptimum` (an ordered list of strategies per level),
:func:`~setupfix.optimize.exact.least_norm.grid.grid_least_norm` →
:class:`~setupfix.optimize.exact.least_norm.grid.LeastNorm`, or the triage
(:func:`~setupfix.optimize.exact.triage.solve.triaged_result`).  Which proof is tried and how work is
shared: :class:`~setupfix.optimize.exact.settings.ExactSettings`.

1. **LP bound** — maximise t subject to every margin ≥ t and the register bounds;
   t_LP bounds every correction.  Its dual prices name the binding dimensions.
   From the same duals, :func:`~setupfix.optimize.exact.grid.dual_bound` re-proves the
   bound in numpy, and :func:`~setupfix.optimize.exact.grid.pair_bound` lowers it where
   two dimensions move alike and the even split of their difference is off the
   grid.  U = the smaller of the two bounds every grid point must respect.
2. **Grid optimum** — if the LP point rounded to the grid already reaches U, it is
   optimal (nothing on the grid exceeds U): no MILP.  Otherwise levels of rounded rows
   from U down: an empty continuous system lowers the level; small problems list growing
   ellipsoids around its continuous least-norm point (bounded work): a point found reaches
   the level, a list that closes also proves the least norm there (stage 3 is skipped), a
   list holding the whole box with no point proves the level empty; then a feasibility
   MILP; only then the MILP "max t, k integer", bracketed t ∈ [t(rounded point), U],
   started from the rounded point.
   A HiGHS failure ("Solve error") is retried once with the lower bracket removed,
   and reported as such in ``notes``.
3. **Least norm** — among grid points with margin ≥ t*, the least Σ cost_i·k_i²
   (eq. 9; cost = 1 by default).  The continuous QP (NNLS; on a working set of rows
   for large problems) gives a point and multipliers; the multipliers bound every
   feasible point's norm from below by an ellipsoid around that point
   (:func:`~setupfix.optimize.exact.least_norm.listing.lagrangian_ball`), and the integer points inside
   it that could beat the best known point are listed exhaustively, pruned by the rows
   and by the Lagrangian dual bound of the coordinates not yet fixed
   (:func:`~setupfix.optimize.exact.least_norm.listing.enumerate_ball`) — the least one is the proven grid
   least norm (ties: the lexicographically smallest).  If the best known point already meets the bound,
   nothing is listed.  Large problems (more than ``ellipsoid_max_registers`` free
   registers, or a list too long): a near-least incumbent from the least norm in the
   unit box around the rounded continuous point (one MILP with a linear objective;
   one step wider if that box is empty), then the exact chord MILP — on integers k²
   is the upper envelope of the chords (2j+1)|k| − j(j+1), added lazily where a
   solution violates s_i ≥ k_i² — restricted to the box the same multipliers prove
   holds every point at most as large as the incumbent
   (:func:`~setupfix.optimize.exact.least_norm.shop.lagrangian_box`).  If the limit stops the
   proof, the best point is improved by coordinate descent and the result states a
   certified bound on ‖x‖ / least norm (``norm_ratio_max``).

Objective
---------
``objective="leximin"`` (the default) goes on after stage 2: with the smallest margin t* (the
paper's δ, eq. 8, leximin's first level) held, the next smallest dimension margin is raised as far
as the grid allows, then the next, and so on — every dimension centred as far as the others allow
(:mod:`setupfix.optimize.exact.leximin.levels`: each level proved by an LP bound, rounded rows or a MILP; a
discrete conflict by branches or counts; a position zone is one dimension, its margin the least of
its polygon's facets, :func:`~setupfix.optimize.dimensions.dimension_of_rows`) — and stage 3 runs among
the leximin-optimal grid points (every dimension's margin at least its level); the levels may use all
but ``leximin_norm_share`` of the work budget.  ``objective="paper"`` stops after stage 2 and runs stage 3 at t*
(eqs. 8–9 exactly, what ``compare`` and the paper's validation use).

Work, not time
--------------
The stages share one **work budget** (``ExactSettings.work_limit``; :mod:`setupfix.optimize.exact.work`):
HiGHS's iterations and nodes and the heavier numpy steps are counted, never seconds, so which stage
ends, and where, is the same on an idle machine and on a loaded one.  The grid-optimum stage stops
when ``least_norm_share`` of the budget is left, so the least-norm stage always runs: if a stage
stops at its share, its best point is used, the least-norm stage still shrinks the correction at the
error budget reached, and the status (``time_limit``), the message, ``notes`` and ``stopped`` (reason
"work limit") say which stage stopped.  The LP bound is always reported.

The optimiser's ``time_limit`` (``--time-limit``) only guards against a hang: when the wall clock
passes it, the solve gives **no correction** (x = 0, ``stopped`` reason "time limit"), never a
different one (:func:`~setupfix.optimize.exact.solve.guarded`).
"""

from setupfix.optimize.exact.settings import ExactSettings
from setupfix.optimize.exact.solve import ExactOptimizer

__all__ = ["ExactOptimizer", "ExactSettings"]
