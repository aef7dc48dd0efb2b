"""Stage 2 of the exact solve: the largest error budget t* = max t(k) over the register grid (eq. 8).

Grid units as in :mod:`setupfix.optimize.exact.session`.  The bound U = min(dual bound, pair
bound) ≤ t_LP holds for every grid point (:func:`~setupfix.optimize.exact.grid.dual_bound`,
:func:`~setupfix.optimize.exact.grid.pair_bound`).  If the LP point rounded to the grid reaches
U, it is optimal.  Otherwise the stage descends by *levels* τ (from U down): the rows
rounded at τ, b = d·⌊(g − τ)/d⌋, hold every grid point with t(k) ≥ τ
(:func:`~setupfix.optimize.exact.grid.rounded_rhs`).  At each level an ordered list of
strategies is tried; each answers with a :class:`StrategyAnswer`:

``reached``    a grid point with t(k) ≥ τ is found: t* = τ' ≥ τ is proved (no point beats U,
               and every level above τ was proved empty);
``empty``      no grid point meets the rounded rows: t* ≤ the next level down;
``undecided``  the next strategy is tried;
``give_up``    the descent stops; the bracketed MILP decides.

The strategies, cheapest first: the continuous least norm of the rounded rows (empty
relaxation → empty level), its rounded point, the listing of the dual ellipsoids around it
(small problems; the whole box listed without a point → empty level) or the MILPs in the
unit box around it (large problems), a feasibility MILP.  Last, once: the MILP
"max t, k integer" bracketed t ∈ [t(best point), U] and started from the best point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note
from setupfix.optimize.exact.grid import TOL, dual_bound, grid_margins, pair_bound
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.least_norm.listing import ellipsoid_search, lagrangian_ball
from setupfix.optimize.exact.least_norm.shop import box_least_norm
from setupfix.optimize.exact.lp_bound import LPBound
from setupfix.optimize.exact.session import Relaxation, Session
from setupfix.optimize.exact.work import now
from setupfix.optimize.problem import Stopped

__all__ = [
    "LEVEL_STRATEGIES",
    "GridOptimum",
    "GridLevel",
    "Listed",
    "Search",
    "StrategyAnswer",
    "UnitBox",
    "grid_optimum",
    "searched",
]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Listed:
    """The least norm among grid points meeting rows ``b`` was proved by the listing (``count`` points)."""

    b: Array
    count: int


@dataclass(frozen=True)
class UnitBox:
    """The unit box around the relaxation of rows ``b`` was searched: ``found`` a point, or it is empty."""

    b: Array
    found: bool


@dataclass(frozen=True)
class GridLevel:
    """What the strategies see at one level: τ [steps], its rounded rows b (r,), the best point so far."""

    tau: float
    b: Array
    k: Array
    t: float
    relaxation: Relaxation | None
    stage_end: float  # ``now()`` at which the stage's share of the limit is spent

    def left(self) -> float:
        return self.stage_end - now()


#: A strategy's verdict on one level (see the module text).
Verdict = Literal["reached", "empty", "undecided", "give_up"]


@dataclass(frozen=True)
class StrategyAnswer:
    """A strategy's answer at one level (see the module text); ``k`` a grid point found (shape (n,))."""

    verdict: Verdict
    k: Array | None = None
    relaxation: Relaxation | None = None
    text: str = ""  # path entry when reached, or when the lowered level is attained (empty)
    path: tuple[str, ...] = ()
    calls: int = 0
    listed: Listed | None = None
    unit_box: UnitBox | None = None


@dataclass(frozen=True)
class GridOptimum:
    """Outcome of stage 2: the best grid point (k [steps], t = t(k)), the proven bound ``upper`` ≥ t*,
    and what the least-norm stage may reuse (each tagged with the rows it holds for)."""

    k: Array
    t: float
    upper: float
    stopped: Stopped | None
    relaxation: Relaxation | None
    listed: Listed | None
    unit_box: UnitBox | None
    path: tuple[str, ...]
    notes: tuple[Note, ...]
    calls: int


_NEAR = "grid optimum: a grid point near the rounded rows' least-norm point attains the bound"
_LOWERED = "grid optimum: best point attains the bound lowered by infeasible levels"


def relax(session: Session, level: GridLevel) -> StrategyAnswer:
    """The continuous least norm of the rounded rows; an empty relaxation proves the level empty."""
    if session.small:
        status, relaxation = session.least_norm(level.b)
    else:  # large: whether the rounded rows are feasible (an LP), then their least-norm point
        status, _ = session.rounded_rows_feasible(level.b)
        relaxation = session.least_norm(level.b)[1] if status == "optimal" else None
        if status == "optimal":
            return StrategyAnswer("undecided", relaxation=relaxation)
    if relaxation is not None:
        return StrategyAnswer("undecided", relaxation=relaxation)
    if status != "infeasible" or not session.rows.all_integer:
        return StrategyAnswer("give_up")
    return StrategyAnswer("empty", text="grid optimum: rounded LP point attains the rounded-rows bound")


def _reaches(session: Session, k: Array | None, tau: float) -> bool:
    return k is not None and float(grid_margins(session.rows.g_rows, session.rows.g, k)) >= tau - TOL


def rounded_relaxation(session: Session, level: GridLevel) -> StrategyAnswer:
    """The relaxation's point rounded to the grid."""
    if level.relaxation is None:
        return StrategyAnswer("undecided")
    k = np.clip(np.rint(level.relaxation.k), session.rows.kmin, session.rows.kmax)
    reached = _reaches(session, k, level.tau)
    return StrategyAnswer(
        "reached" if reached else "undecided",
        k=k,
        text="grid optimum: least-norm point of the rounded rows attains the bound",
    )


def listing(session: Session, level: GridLevel) -> StrategyAnswer:
    """Small problems: grid points in growing dual ellipsoids around the relaxation (bounded work).

    A point found reaches the level (and a list that closes proves the least norm there too);
    a list holding the whole box without a point proves the level empty.
    """
    rel, rows, s = level.relaxation, session.rows, session.settings
    if rel is None or not session.small:
        return StrategyAnswer("undecided")
    fin = np.isfinite(level.b)
    centre, q = lagrangian_ball(
        rows.g_rows[fin], level.b[fin], rows.kmin, rows.kmax, rows.cost, rel.lam_rows[fin], rel.lam_lo, rel.lam_hi
    )
    found, least, listed = ellipsoid_search(
        rows.g_rows,
        rows.g,
        level.tau,
        centre,
        q,
        rows.cost,
        rows.kmin,
        rows.kmax,
        np.inf,
        s.search_limit,
        level.b,
        work_limit=s.search_work,
        multipliers=rel.multipliers(),
    )
    if found is not None:
        return StrategyAnswer("reached", k=found, text=_NEAR, listed=Listed(level.b, listed) if least else None)
    if least and rows.all_integer:
        return StrategyAnswer(
            "empty",
            text=_LOWERED,
            path=(f"grid optimum: no grid point at {level.tau:.4g} steps (the whole box listed)",),
        )
    return StrategyAnswer("undecided")


def unit_boxes(session: Session, level: GridLevel) -> StrategyAnswer:
    """Large problems: the least norm in the unit box around the relaxation (a MILP), then ±1 (feasibility)."""
    rel, rows, s = level.relaxation, session.rows, session.settings
    if rel is None or session.small or level.left() <= 0:
        return StrategyAnswer("undecided")
    res, found = box_least_norm(
        rows.g_rows,
        level.b,
        np.clip(np.floor(rel.k), rows.kmin, rows.kmax),
        np.clip(np.ceil(rel.k), rows.kmin, rows.kmax),
        rows.cost,
        level.left() * s.milp_share / 2,
        gap=s.incumbent_gap,
    )
    path = [f"grid optimum: box MILP ±0 around the rounded rows' least-norm point ({res.status})"]
    found = found if _reaches(session, found, level.tau) else None
    settled = UnitBox(level.b, found is not None) if found is not None or res.status == "infeasible" else None
    calls = 1
    if found is None and res.status == "infeasible" and level.left() > 0:  # any point one step wider
        fin = np.isfinite(level.b)
        lo = np.clip(np.floor(rel.k) - 1, rows.kmin, rows.kmax)
        hi = np.clip(np.ceil(rel.k) + 1, rows.kmin, rows.kmax)
        wide = LinearModel(
            np.zeros(rows.n_free),
            rows.g_rows[fin],
            np.full(int(fin.sum()), -INF),
            level.b[fin],
            lo,
            hi,
            integer=np.ones(rows.n_free, bool),
        ).solve(level.left() * s.milp_share / 2)
        calls += 1
        path.append(f"grid optimum: feasibility MILP ±1 around it ({wide.status})")
        if wide.x is not None:
            found = np.clip(np.rint(wide.x), lo, hi)
            found = found if _reaches(session, found, level.tau) else None
    return StrategyAnswer(
        "reached" if found is not None else "undecided",
        k=found,
        text=_NEAR,
        path=tuple(path),
        calls=calls,
        unit_box=settled,
    )


def feasibility_milp(session: Session, level: GridLevel) -> StrategyAnswer:
    """A feasibility MILP on the rounded rows: a point reaches the level, a proof of infeasibility empties it."""
    rows = session.rows
    if level.left() <= 0:
        return StrategyAnswer("give_up")
    fin = np.isfinite(level.b)
    feas = LinearModel(
        np.zeros(rows.n_free),
        rows.g_rows[fin],
        np.full(int(fin.sum()), -INF),
        level.b[fin],
        rows.kmin,
        rows.kmax,
        integer=np.ones(rows.n_free, bool),
    ).solve(level.left() * session.settings.milp_share)
    path = (f"grid optimum: feasibility MILP at {level.tau:.4g} steps ({feas.status}, {feas.seconds:.0f} work units)",)
    k = None if feas.x is None else np.clip(np.rint(feas.x), rows.kmin, rows.kmax)
    if _reaches(session, k, level.tau):
        return StrategyAnswer(
            "reached",
            k=k,
            path=path,
            calls=1,
            text="grid optimum: a feasibility MILP on the rounded rows reaches the bound",
        )
    if feas.status == "infeasible" and rows.all_integer:
        return StrategyAnswer("empty", k=k, path=path, calls=1, text=_LOWERED)
    return StrategyAnswer("give_up", k=k, path=path, calls=1)


#: The strategies tried at each level, in this order.
LEVEL_STRATEGIES: tuple[Callable[[Session, GridLevel], StrategyAnswer], ...] = (
    relax,
    rounded_relaxation,
    listing,
    unit_boxes,
    feasibility_milp,
)

#: A caller's local search on the grid: from a grid point to a point at least as good (None: it does not search).
Search = Callable[[Array], Array | None]


def searched(search: Search) -> Callable[[Session, GridLevel], StrategyAnswer]:
    """A strategy from a caller's search (the leximin levels' grid climb), started at the relaxation's point
    rounded; tried before the listing, which it spares where it reaches the level."""

    def strategy(session: Session, level: GridLevel) -> StrategyAnswer:
        if level.relaxation is None:
            return StrategyAnswer("undecided")
        rows = session.rows
        k = search(np.clip(np.rint(level.relaxation.k), rows.kmin, rows.kmax))
        if k is None:
            return StrategyAnswer("undecided")
        return StrategyAnswer(
            "reached" if _reaches(session, k, level.tau) else "undecided",
            k=k,
            text="grid optimum: the leximin levels' climb from the rounded rows' least-norm point attains the bound",
        )

    return strategy


def grid_optimum(session: Session, bound: LPBound, search: Search | None = None) -> GridOptimum:
    """Stage 2: the grid optimum t*, proved, or the best point when its share of the limit is spent.

    ``search``: a caller's local search, tried after the rounded relaxation (:func:`searched`).
    """
    rows, clock = session.rows, session.clock
    upper = min(
        dual_bound(rows.g_rows, rows.g, bound.y, rows.kmin, rows.kmax),
        pair_bound(rows.g_rows, rows.g, rows.kmin, rows.kmax, rows.pairs),
    )
    k_best = np.clip(np.rint(bound.k), rows.kmin, rows.kmax)
    t_best = float(grid_margins(rows.g_rows, rows.g, k_best))
    zero = np.zeros_like(k_best)
    if float(grid_margins(rows.g_rows, rows.g, zero)) >= t_best:  # no correction at all is a grid point too
        k_best, t_best = zero, float(grid_margins(rows.g_rows, rows.g, zero))
    if upper < -TOL:
        return GridOptimum(
            k_best,
            t_best,
            upper,
            None,
            None,
            None,
            None,
            ("grid optimum: the bound is below 0 (no correction brings every dimension into tolerance)",),
            (),
            0,
        )
    if t_best >= upper - TOL:
        return GridOptimum(
            k_best, t_best, upper, None, None, None, None, ("grid optimum: rounded LP point attains the bound",), (), 0
        )
    stage_end = clock.deadline - session.settings.least_norm_share * session.time_limit
    strategies = (
        LEVEL_STRATEGIES if search is None else (*LEVEL_STRATEGIES[:2], searched(search), *LEVEL_STRATEGIES[2:])
    )
    tau, relaxation, listed, unit_box = upper, None, None, None
    path: list[str] = []
    calls, proved = 0, False
    for _ in range(session.settings.level_steps):
        if now() >= stage_end:
            break
        level = GridLevel(tau, rows.rounded(tau), k_best, t_best, None, stage_end)
        calls += 1
        verdict: Verdict = "give_up"  # when every strategy is undecided
        for strategy in strategies:
            step = strategy(session, level)
            calls += step.calls
            path.extend(step.path)
            relaxation = step.relaxation or relaxation
            listed, unit_box = step.listed or listed, step.unit_box or unit_box
            if step.k is not None and float(grid_margins(rows.g_rows, rows.g, step.k)) > t_best:
                k_best, t_best = step.k, float(grid_margins(rows.g_rows, rows.g, step.k))
            level = GridLevel(tau, level.b, k_best, t_best, step.relaxation or level.relaxation, stage_end)
            if step.verdict != "undecided":
                verdict = step.verdict
                break
        if verdict == "empty":
            tau = rows.below(level.b)  # nothing on the grid above this level
            proved = t_best >= tau - TOL
        else:
            proved = verdict == "reached"
        if proved:
            path.append(step.text)
        if verdict != "empty" or proved:
            break
    upper = min(upper, tau)
    if proved:
        return GridOptimum(k_best, t_best, upper, None, relaxation, listed, unit_box, tuple(path), (), calls)
    return _bracketed_milp(session, k_best, t_best, upper, stage_end, relaxation, listed, unit_box, path, calls)


def _bracketed_milp(
    session: Session,
    k_best: Array,
    t_best: float,
    upper: float,
    stage_end: float,
    relaxation: Relaxation | None,
    listed: Listed | None,
    unit_box: UnitBox | None,
    path: list[str],
    calls: int,
) -> GridOptimum:
    """The MILP "max t, k integer" with t ∈ [t(best point), U], started from the best point."""
    rows = session.rows
    if now() >= stage_end:  # its share of the limit is spent: no MILP
        path.append("grid optimum: its share of the time limit spent before the MILP")
        return GridOptimum(
            k_best,
            t_best,
            upper,
            Stopped("grid optimum", "time limit"),
            relaxation,
            listed,
            unit_box,
            tuple(path),
            (),
            calls,
        )
    notes: list[Note] = []
    res = session.max_margin_milp(t_best, upper, k_best, stage_end - now())
    calls += 1
    if res.status == "error":
        notes.append(
            Note(
                f"HiGHS answered {res.detail!r} on the grid MILP bracketed by the best grid point "
                f"({t_best:.4g}) and the bound ({upper:.4g} steps); retried without the lower bracket",
                kind="solver",
            )
        )
        calls += 1
        res = session.max_margin_milp(-INF, upper, None, stage_end - now())
    if res.x is not None:
        k = np.clip(np.rint(res.x[:-1]), rows.kmin, rows.kmax)
        t_k = float(grid_margins(rows.g_rows, rows.g, k))
        if t_k > t_best:
            k_best, t_best = k, t_k
    path.append(f"grid optimum: MILP ({res.status})")
    stopped = None
    if res.status != "optimal":
        stopped = Stopped("grid optimum", "time limit" if res.status == "time_limit" else f"HiGHS: {res.detail}")
    return GridOptimum(k_best, t_best, upper, stopped, relaxation, listed, unit_box, tuple(path), tuple(notes), calls)
