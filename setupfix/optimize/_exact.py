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
Each stage is a function of the solve's :class:`~setupfix.optimize._session.Session` that
returns a frozen result: :func:`~setupfix.optimize._lp_bound.lp_bound` →
:class:`~setupfix.optimize._lp_bound.LPBound`, :func:`~setupfix.optimize._grid_optimum.grid_optimum`
→ :class:`~setupfix.optimize._grid_optimum.GridOptimum` (an ordered list of strategies per level),
:func:`~setupfix.optimize._grid_least_norm.grid_least_norm` →
:class:`~setupfix.optimize._grid_least_norm.LeastNorm`, or the triage
(:func:`~setupfix.optimize._triage.triaged_result`).  Which proof is tried and how time is
shared: :class:`~setupfix.optimize._settings.ExactSettings`.

1. **LP bound** — maximise t subject to every margin ≥ t and the register bounds;
   t_LP bounds every correction.  Its dual prices name the binding dimensions.
   From the same duals, :func:`~setupfix.optimize._grid.dual_bound` re-proves the
   bound in numpy, and :func:`~setupfix.optimize._grid.pair_bound` lowers it where
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
   (:func:`~setupfix.optimize._listing.lagrangian_ball`), and the integer points inside
   it that could beat the best known point are listed exhaustively, pruned by the rows
   and by the Lagrangian dual bound of the coordinates not yet fixed
   (:func:`~setupfix.optimize._listing.enumerate_ball`) — the least one is the proven grid
   least norm (ties: the lexicographically smallest).  If the best known point already meets the bound,
   nothing is listed.  Large problems (more than ``ellipsoid_max_registers`` free
   registers, or a list too long): a near-least incumbent from the least norm in the
   unit box around the rounded continuous point (one MILP with a linear objective;
   one step wider if that box is empty), then the exact chord MILP — on integers k²
   is the upper envelope of the chords (2j+1)|k| − j(j+1), added lazily where a
   solution violates s_i ≥ k_i² — restricted to the box the same multipliers prove
   holds every point at most as large as the incumbent
   (:func:`~setupfix.optimize._least_norm.lagrangian_box`).  If the limit stops the
   proof, the best point is improved by coordinate descent and the result states a
   certified bound on ‖x‖ / least norm (``extra["norm_ratio_max"]``).

Objective
---------
``objective="leximin"`` (the default) goes on after stage 2: with the smallest margin t* (the
paper's δ, eq. 8, leximin's first level) held, the next smallest dimension margin is raised as far
as the grid allows, then the next, and so on — every dimension centred as far as the others allow
(:mod:`setupfix.optimize._leximin`: each level proved by an LP bound, rounded rows or a MILP; a
discrete conflict by branches or counts; a position zone is one dimension, its margin the least of
its polygon's facets, :func:`~setupfix.optimize._dimensions.dimension_of_rows`) — and stage 3 runs among
the leximin-optimal grid points (every dimension's margin at least its level); the levels may use all
but ``leximin_norm_share`` of the limit.  ``objective="paper"`` stops after stage 2 and runs stage 3 at t*
(eqs. 8–9 exactly, what ``compare`` and the paper's validation use).

One ``time_limit`` bounds the wall time of the whole solve, counted from the solve's own
start (each solve has its own session; nothing of an earlier solve's clock carries over).  The
grid-optimum stage stops when ``least_norm_share`` of the limit is left, so the least-norm stage always runs: if a
stage stops at the limit, its best point is used, the least-norm stage still
shrinks the correction at the error budget reached, and the status, the message,
``notes`` and ``extra["stopped"]`` say which stage stopped and why.  The LP bound
is always reported.
"""

from __future__ import annotations

import time
from contextlib import AbstractContextManager
from typing import ClassVar

import numpy as np
import numpy.typing as npt
from threadpoolctl import ThreadpoolController

from setupfix.errors import Note
from setupfix.optimize._base import Optimizer, make_result
from setupfix.optimize._dimensions import dimension_of_rows, model_dimensions
from setupfix.optimize._grid import TOL
from setupfix.optimize._grid_least_norm import LeastNorm, grid_least_norm
from setupfix.optimize._grid_optimum import GridOptimum, Stop, grid_optimum
from setupfix.optimize._least_norm import lower_bound_ratio
from setupfix.optimize._leximin import leximin, leximin_least_norm, root_climb
from setupfix.optimize._leximin_level import LevelValue
from setupfix.optimize._lp_bound import LPBound, lp_bound, margin_rows, rows_to_dimensions
from setupfix.optimize._problem import CorrectionProblem, OptimizeResult
from setupfix.optimize._session import Clock, GridRows, Session
from setupfix.optimize._settings import ExactSettings
from setupfix.optimize._triage import triaged_result
from setupfix.params import Constraint, Interval, Options

__all__ = ["ExactOptimizer", "ExactSettings", "margin_rows"]

Array = npt.NDArray[np.float64]

_CONTROLLER: ThreadpoolController | None = None
#: The settings an optimiser gets by default (frozen: shared safely).
DEFAULT_SETTINGS = ExactSettings()


def _blas_single_thread() -> AbstractContextManager[object]:
    """BLAS limited to one thread; the controller (a scan of loaded libraries, no solver state) is made once."""
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    limiter: AbstractContextManager[object] = _CONTROLLER.limit(limits=1)
    return limiter


class ExactOptimizer(Optimizer):
    """Provably optimal corrections on the register grid (the default optimiser).

    Parameters
    ----------
    grid : bool, default=True
        Solve on the register grid.  False returns the continuous LP optimum with
        the least weighted Euclidean norm (not on the grid).
    time_limit : float, default=2.0
        Seconds of wall time for the whole solve; when a stage hits it, the best
        point found is used and the result says which stage stopped.
    seed : int, optional
        Accepted for interface symmetry; the solver is deterministic.
    settings : ExactSettings, optional
        Which proofs are tried and how the time is shared (defaults: ``ExactSettings()``).
    objective : {"leximin", "paper"}, default="leximin"
        ``"leximin"``: the sorted dimension margins maximised lexicographically (first level = the
        paper's δ), then the least Σ cost·x²; ``"paper"``: eqs. 8–9 (δ, then the least norm).
        ``result.extra["leximin"]`` lists the leximin levels ([margin, how many dimensions]).

    Every :meth:`solve` opens its own :class:`~setupfix.optimize._session.Session`: no solver
    model or state outlives it, so a report's answer never depends on what was solved before.
    """

    name = "exact"
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "grid": [bool],
        "time_limit": [Interval(float, 0.0, None, closed="neither")],
        "seed": [Interval(int, 0, None), None],
        "settings": [ExactSettings],
        "objective": [Options({"leximin", "paper"})],
    }

    def __init__(
        self,
        *,
        grid: bool = True,
        time_limit: float = 2.0,
        seed: int | None = None,
        settings: ExactSettings = DEFAULT_SETTINGS,
        objective: str = "leximin",
    ) -> None:
        self.objective = objective
        self.grid = grid
        self.time_limit = time_limit
        self.seed = seed
        self.settings = settings

    def solve(self, problem: CorrectionProblem) -> OptimizeResult:
        # What the stages import lazily (to keep `import setupfix` light) is imported before the clock
        # starts: the first solve of a process would otherwise spend ~0.1 s of its time limit on it.
        import scipy.optimize  # noqa: F401 - loaded for _grid.nnls_least_distance, outside the clock

        with _blas_single_thread():  # small solves: BLAS threads only contend
            return self._solve(problem)

    def _solve(self, problem: CorrectionProblem) -> OptimizeResult:
        clock = Clock(self.time_limit)
        start = clock.start
        free = problem.free
        x = np.zeros(problem.n_registers)
        g_rows, g = margin_rows(problem, self.settings.quantum)
        if free.sum() == 0 or g.size == 0:
            return make_result(
                problem,
                x,
                optimizer=self.name,
                evaluations=0,
                seconds=time.perf_counter() - start,
                status="optimal",
                bound=problem.margin_before,
                message="nothing can be corrected: every register is fixed or no limit applies",
            )
        rows = GridRows(
            g_rows, g, problem.kmin[free].astype(float), problem.kmax[free].astype(float), problem.cost[free]
        )
        session = Session(rows, self.settings, self.time_limit, clock)
        lp = lp_bound(session)
        if lp is None:  # not even the LP bound within the limit: no correction, and says so
            text = (
                f"the LP bound was not proved within the time limit ({self.time_limit:g} s): no correction "
                "is recommended; allow more time (--time-limit)"
            )
            result = make_result(
                problem,
                x,
                optimizer=self.name,
                evaluations=1,
                seconds=time.perf_counter() - start,
                status="time_limit",
                message=text,
            )
            result.notes = (Note(text, kind="solver"),)
            result.extra.update(
                {"stopped": {"stage": "lp bound", "reason": "time limit"}, "path": "lp bound: time limit"}
            )
            return result
        binding = rows_to_dimensions(problem, lp.y > 1e-9)
        bound = lp.t * problem.resolution
        session.clock.lap("lp bound")
        if not self.grid:
            _, cont = session.least_norm(g - lp.t + 1e-8)
            x[free] = (lp.k if cont is None else cont.k) * problem.resolution
            session.clock.lap("least norm")
            return make_result(
                problem,
                x,
                optimizer=self.name,
                evaluations=2,
                seconds=time.perf_counter() - start,
                status="optimal",
                bound=bound,
                binding=binding,
            )
        climbed: list[Array] = []  # the leximin levels' first climb, where the grid optimum ran it
        dims: tuple[npt.NDArray[np.intp], int] | None = None  # leximin: each row's dimension, how many
        if self.objective == "leximin":
            row_dim = dimension_of_rows(problem)  # a zone's facets are one dimension: its margin, their least
            n_dims = len(model_dimensions(problem)[0])
            dims = (row_dim, n_dims)

            def climb(k: Array) -> Array | None:
                out = root_climb(session, row_dim, n_dims, k)
                climbed.extend([] if out is None else [out])
                return out

            opt = grid_optimum(session, lp, climb)
        else:
            opt = grid_optimum(session, lp)
        session.clock.lap("grid optimum")
        calls = 1 + opt.calls
        if opt.upper < -TOL or (opt.stopped is None and opt.t < -TOL):
            return triaged_result(problem, session, opt.k, list(opt.path), list(opt.notes), calls, bound, self.name)
        if dims is not None and opt.stopped is None:
            k_climb = climbed[-1] if climbed and np.array_equal(climbed[-1], opt.k) else None
            return self._leximin(problem, session, lp, opt, calls, bound, binding, dims, k_climb)
        least, calls = self._least_norm(session, opt, calls)
        session.clock.lap("least norm")
        x[free] = least.k * problem.resolution
        return self._result(problem, session, x, opt, least, calls, bound, binding)

    def _leximin(
        self,
        problem: CorrectionProblem,
        session: Session,
        lp: LPBound,
        opt: GridOptimum,
        calls: int,
        bound: float,
        binding: tuple[str, ...],
        dims: tuple[npt.NDArray[np.intp], int],
        k_climb: Array | None,
    ) -> OptimizeResult:
        """Levels 2, 3 … after the proved first level (the paper's δ), then the least norm among the
        leximin-optimal grid points (:mod:`setupfix.optimize._leximin`); ``dims``: each row's dimension and
        how many there are; ``k_climb``: the levels' first climb where the grid-optimum stage ran it and
        took its point."""
        row_dim, n_dims = dims
        stage_end = session.clock.deadline - self.settings.leximin_norm_share * self.time_limit
        lex = leximin(
            session,
            row_dim,
            n_dims,
            opt.k,
            opt.t,
            first=LevelValue(opt.t, opt.k, lp.t, lp.y),
            stage_end=stage_end,
            k_climb=k_climb,
        )
        session.clock.lap("leximin")
        share = self.settings.box_share if lex.stopped is None else self.settings.stopped_box_share
        least = leximin_least_norm(session, lex, row_dim, share)
        session.clock.lap("least norm")
        x = np.zeros(problem.n_registers)
        x[problem.free] = least.k * problem.resolution
        opt = GridOptimum(
            lex.k, opt.t, opt.upper, lex.stopped, None, None, None, opt.path + lex.path, opt.notes, calls + lex.calls
        )
        result = self._result(problem, session, x, opt, least, calls + lex.calls, bound, binding)
        h = problem.resolution
        result.extra["leximin"] = [[value * h, count] for value, count in lex.levels]
        return result

    def _least_norm(self, session: Session, opt: GridOptimum, calls: int) -> tuple[LeastNorm, int]:
        """Stage 3 at the error budget reached (also when stage 2 was stopped), unless stage 2 proved it."""
        b = session.rows.rounded(opt.t)
        if opt.listed is not None and np.array_equal(b, opt.listed.b):
            return LeastNorm(
                opt.k,
                True,
                "",
                float(np.sum(session.rows.cost * opt.k**2)),
                (f"least norm: {opt.listed.count} grid points in the dual ellipsoid (listed with the grid optimum)",),
            ), calls
        relaxation = opt.relaxation if opt.relaxation is not None and np.array_equal(b, opt.relaxation.b) else None
        unit_box = opt.unit_box.found if opt.unit_box is not None and np.array_equal(b, opt.unit_box.b) else None
        share = self.settings.box_share if opt.stopped is None else self.settings.stopped_box_share
        return grid_least_norm(session, opt.t, b, opt.k, relaxation, unit_box, share), calls + 1

    def _result(
        self,
        problem: CorrectionProblem,
        session: Session,
        x: Array,
        opt: GridOptimum,
        least: LeastNorm,
        calls: int,
        bound: float,
        binding: tuple[str, ...],
    ) -> OptimizeResult:
        """The result: status, message and notes say which stage stopped and why (none: optimal)."""
        stopped = opt.stopped if opt.stopped is not None or least.proved else Stop("least norm", least.why)
        notes = list(opt.notes)
        status, message = "optimal", None
        extra: dict[str, object] = {"stages": dict(session.clock.stages), "path": "; ".join(opt.path + least.path)}
        if stopped is not None:
            status = "time_limit" if stopped.reason == "time limit" else "solver_error"
            if stopped.stage == "leximin":
                message = (
                    f"paper's optimum proved, leximin levels not all proved ({stopped.reason} in the "
                    "leximin stage); the least-norm correction at the levels reached is given"
                )
            elif stopped.stage == "grid optimum":
                message = (
                    f"grid optimum not proved ({stopped.reason} in the grid-optimum stage); the least-norm "
                    f"correction at the best error budget found is given; the continuous bound is "
                    f"{bound:.4f}"
                )
            else:
                message = (
                    f"grid optimum proved, least norm not proved ({stopped.reason} in the least-norm "
                    "stage); the smallest correction found at the optimum is given"
                )
            if not least.proved:
                ratio = lower_bound_ratio(float(np.sum(session.rows.cost * least.k**2)), least.lower)
                extra["norm_ratio_max"] = ratio
                message += (
                    f", at most {ratio:.3f}× the least norm (certified)"
                    if np.isfinite(ratio)
                    else ", with no bound on how far it is from the least norm"
                )
            notes.append(Note(message, kind="solver"))
            extra["stopped"] = {"stage": stopped.stage, "reason": stopped.reason}
        result = make_result(
            problem,
            x,
            optimizer=self.name,
            evaluations=calls,
            seconds=time.perf_counter() - session.clock.start,
            status=status,
            bound=bound,
            message=message,
            binding=binding,
        )
        result.extra.update(extra)
        result.notes = tuple(notes)
        return result
