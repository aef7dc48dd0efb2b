"""The exact optimiser: the stages of the package docstring run in order, within one work budget.

The budget is work (``ExactSettings.work_limit``, :mod:`setupfix.optimize.exact.work`): a stage stopped
by it gives the same answer under any load (``stopped.reason`` "work limit").  The wall-clock
``time_limit`` only guards against a hang: when it fires, the solve recommends **no correction**
(x = 0, status ``time_limit``, ``stopped.reason`` "time limit"), never a different one.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from dataclasses import replace
from typing import ClassVar

import numpy as np
import numpy.typing as npt
from threadpoolctl import ThreadpoolController

from setupfix.core.errors import Note
from setupfix.core.params import Constraint, Interval, Options
from setupfix.optimize.base import Optimizer, make_result
from setupfix.optimize.dimensions import dimension_of_rows, model_dimensions
from setupfix.optimize.exact.grid import TOL
from setupfix.optimize.exact.grid_optimum import GridOptimum, grid_optimum
from setupfix.optimize.exact.least_norm.grid import LeastNorm, grid_least_norm
from setupfix.optimize.exact.least_norm.shop import lower_bound_ratio
from setupfix.optimize.exact.leximin.level import LevelValue
from setupfix.optimize.exact.leximin.levels import leximin, leximin_least_norm, root_climb
from setupfix.optimize.exact.lp_bound import LPBound, lp_bound, margin_rows, rows_to_dimensions
from setupfix.optimize.exact.session import Clock, GridRows, Session
from setupfix.optimize.exact.settings import ExactSettings
from setupfix.optimize.exact.triage.solve import triaged_result
from setupfix.optimize.exact.work import CURRENT, wall
from setupfix.optimize.problem import CorrectionProblem, OptimizeResult, Status, Stopped

__all__ = ["ExactOptimizer", "ExactSettings", "margin_rows"]

Array = npt.NDArray[np.float64]

_CONTROLLER: ThreadpoolController | None = None
#: The wall-clock guard of a solve by default [s]: far above any bundled sample's solve (a hang guard).
DEFAULT_TIME_LIMIT = 60.0
#: The settings an optimiser gets by default (frozen: shared safely).
DEFAULT_SETTINGS = ExactSettings()


def _work_words(text: str) -> str:
    return text.replace("time limit", "work limit")


def guarded(
    problem: CorrectionProblem, result: OptimizeResult, clock: Clock, time_limit: float, optimizer: str
) -> OptimizeResult:
    """The result as the wall-clock guard and the work budget make it.

    Guard fired (``clock.fired``: the solve ran past ``time_limit`` seconds): **no correction**,
    status ``time_limit``, ``stopped`` naming the stage that was running (a hang guard must never
    turn into a different correction).  Otherwise a stage stopped at its limit was stopped by the
    work budget, the same under any load: its words say "work limit".
    """
    if clock.fired:
        stage = result.stopped.stage if result.stopped is not None else (list(clock.stages) or ["lp bound"])[-1]
        text = (
            f"the {stage} stage was not proved within the time limit ({time_limit:g} s, the wall-clock guard "
            "against a hang): no correction is recommended (this is not 'no change needed'); allow more time "
            "(--time-limit)"
        )
        return make_result(
            problem,
            np.zeros(problem.n_registers),
            optimizer=optimizer,
            evaluations=result.evaluations,
            seconds=result.seconds,
            status="time_limit",
            bound=result.bound,
            message=text,
            guard=False,
            notes=(Note(text, kind="solver"),),
            stopped=Stopped(stage, "time limit"),
            path=result.path,
            stages=result.stages,
        )
    stopped = result.stopped
    if stopped is None or "time limit" not in (stopped.reason + (stopped.detail or "")):
        return result
    return replace(
        result,
        stopped=replace(
            stopped,
            reason=_work_words(stopped.reason),
            detail=None if stopped.detail is None else _work_words(stopped.detail),
        ),
        message=None if result.message is None else _work_words(result.message),
        notes=tuple(replace(n, message=_work_words(n.message)) if n.kind == "solver" else n for n in result.notes),
        path=_work_words(result.path),
    )


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
    time_limit : float, default=60.0
        Seconds of wall time after which the solve is stopped as hung (a guard only: the stages
        share the work budget ``settings.work_limit``, never the wall clock).  When it fires, no
        correction is given (x = 0, status ``time_limit``; ``stopped`` names the stage).
    seed : int, optional
        Accepted for interface symmetry; the solver is deterministic.
    settings : ExactSettings, optional
        Which proofs are tried and how the time is shared (defaults: ``ExactSettings()``).
    objective : {"leximin", "paper"}, default="leximin"
        ``"leximin"``: the sorted dimension margins maximised lexicographically (first level = the
        paper's δ), then the least Σ cost·x²; ``"paper"``: eqs. 8–9 (δ, then the least norm).
        ``result.leximin`` lists the leximin levels ([margin, how many dimensions]).

    Every :meth:`solve` opens its own :class:`~setupfix.optimize.exact.session.Session`: no solver
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
        time_limit: float = DEFAULT_TIME_LIMIT,
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
        import scipy.optimize  # noqa: F401 - loaded for grid.nnls_least_distance, outside the clock

        token = CURRENT.set(None)  # this solve's own meter (the clock sets it), dropped at its end
        try:
            with _blas_single_thread():  # small solves: BLAS threads only contend
                clock = Clock(self.settings.work_limit, self.time_limit, self.settings.node_work)
                result = self._solve(problem, clock)
                return replace(guarded(problem, result, clock, self.time_limit, self.name), work=clock.meter.spent)
        finally:
            CURRENT.reset(token)

    def _solve(self, problem: CorrectionProblem, clock: Clock) -> OptimizeResult:
        start = clock.wall_start
        free = problem.free
        x = np.zeros(problem.n_registers)
        g_rows, g = margin_rows(problem, self.settings.quantum)
        if free.sum() == 0 or g.size == 0:
            return make_result(
                problem,
                x,
                optimizer=self.name,
                evaluations=0,
                seconds=wall() - start,
                status="optimal",
                bound=problem.margin_before,
                message="nothing can be corrected: every register is fixed or no limit applies",
            )
        rows = GridRows(
            g_rows, g, problem.kmin[free].astype(float), problem.kmax[free].astype(float), problem.cost[free]
        )
        session = Session(rows, self.settings, self.settings.work_limit, clock)
        lp = lp_bound(session)
        if lp is None:  # not even the LP bound within the limit: no correction, and says so
            text = (
                f"the LP bound was not proved within the time limit ({self.time_limit:g} s): no correction "
                "is recommended; allow more time (--time-limit)"
                if clock.fired
                else "the LP bound was not proved within the work limit: no correction is recommended"
            )
            return make_result(
                problem,
                x,
                optimizer=self.name,
                evaluations=1,
                seconds=wall() - start,
                status="time_limit",
                message=text,
                notes=(Note(text, kind="solver"),),
                stopped=Stopped("lp bound", "time limit" if clock.fired else "work limit"),
                path="lp bound: time limit" if clock.fired else "lp bound: work limit",
            )
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
                seconds=wall() - start,
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
        leximin-optimal grid points (:mod:`setupfix.optimize.exact.leximin.levels`); ``dims``: each row's dimension and
        how many there are; ``k_climb``: the levels' first climb where the grid-optimum stage ran it and
        took its point."""
        row_dim, n_dims = dims
        stage_end = session.clock.deadline - self.settings.leximin_norm_share * session.time_limit
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
        h = problem.resolution
        levels = tuple((value * h, count) for value, count in lex.levels)
        return self._result(problem, session, x, opt, least, calls + lex.calls, bound, binding, levels)

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
        leximin_levels: tuple[tuple[float, int], ...] = (),
    ) -> OptimizeResult:
        """The result: status, message and notes say which stage stopped and why (none: optimal);
        ``leximin_levels``: the leximin levels reached ([margin, how many dimensions], model unit)."""
        stopped = opt.stopped if opt.stopped is not None or least.proved else Stopped("least norm", least.why)
        notes = list(opt.notes)
        status: Status = "optimal"
        message: str | None = None
        ratio: float | None = None
        if stopped is not None:
            status = "time_limit" if stopped.reason in ("time limit", "work limit") else "solver_error"
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
                message += (
                    f", at most {ratio:.3f}× the least norm (certified)"
                    if np.isfinite(ratio)
                    else ", with no bound on how far it is from the least norm"
                )
            notes.append(Note(message, kind="solver"))
        return make_result(
            problem,
            x,
            optimizer=self.name,
            evaluations=calls,
            seconds=wall() - session.clock.wall_start,
            status=status,
            bound=bound,
            message=message,
            binding=binding,
            notes=tuple(notes),
            stopped=stopped,
            norm_ratio_max=ratio,
            leximin=leximin_levels,
            path="; ".join(opt.path + least.path),
            stages=session.clock.stages,
        )
