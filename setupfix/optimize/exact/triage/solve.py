"""Triage: when no correction brings every dimension into tolerance, give up only what must be.

A hopeless dimension must not ruin good ones, and no correction may move a dimension measured in
tolerance out of it (no harm, inside the optimum).  In grid units, with the rows, binaries and
levels of :mod:`~setupfix.optimize.exact.triage.model`, one lexicographic optimum in three stages:

1. **Most dimensions in tolerance, no harm**: max Σ z_q over the dimensions measured out of
   tolerance, every dimension measured in tolerance held by hard rows (margin ≥ its no-harm floor,
   :attr:`~setupfix.optimize.problem.CorrectionProblem.held_floor`; no binary for it).  Optimum N*
   (held + brought in).  Infeasible (the box excludes "no correction"): a refusal.
2. **Leximin of the kept dimensions' margins**: level 1 maximises the smallest kept margin (the error
   budget of the kept dimensions); its multiplicity is the least number of kept margins within the
   quantum of it any such point has; level 2 maximises the next smallest holding level 1, and so on
   (each a MILP with one binary per kept dimension that can fall below the level), until every kept
   position is fixed or the time reserved for stage 3 is reached (level 1 is always solved).
3. **Least norm**: min Σ c_i k_i² subject to N* and every level proved, ties to the lexicographically
   smallest k: in the box c_i k_i² ≤ f(best point) listed when it is small
   (:func:`~setupfix.optimize.exact.triage.model.least_listed`), else a MILP with k_i² as the upper envelope
   of its chords (exact on integers), added lazily (:func:`~setupfix.optimize.exact.least_norm.chords.lazy_chords`), its
   ties then decided coordinate by coordinate (:func:`~setupfix.optimize.exact.least_norm.chords.smallest_tie`).

A dimension is a model dimension (:mod:`~setupfix.optimize.dimensions`): a circular position zone's
polygon facets are its rows, so it is kept (every facet's margin ≥ 0, or ≥ its no-harm floor when held)
or given up (none of its facets constrains) as a whole, and counts once in N* and in the levels.

No point keeps more than N* dimensions, so every point meeting Σ z ≥ N* − held keeps exactly the
dimensions with z = 1 and the held ones; the dimensions given up are read from the final point.
Each MILP is solved to a zero gap by HiGHS; every point it returns is checked exactly
(:meth:`~setupfix.optimize.exact.triage.model.TriageRows.meets`) before it is used.

Order: a small box is listed whole (:func:`~setupfix.optimize.exact.triage.model.listed_triage`); else,
when the kept set is forced (every dimension not kept is proved out of tolerance at every no-harm
point and the others all reach a margin ≥ 0 together), the three stages are the feasible case's
leximin and least norm on the kept dimensions (:mod:`~setupfix.optimize.exact.triage.forced`, no
binaries); else the MILPs above.  Leximin levels left unproved (the time reserved for the least norm
reached) make the result stopped (status ``time_limit``, ``stopped``), never "optimal".
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note
from setupfix.optimize.base import make_result
from setupfix.optimize.dimensions import dimension_floor, dimension_margins, dimension_of_rows, model_dimensions
from setupfix.optimize.exact.highs import INF, LinearModel, Solve
from setupfix.optimize.exact.least_norm.chords import chord_rows, lazy_chords, smallest_tie
from setupfix.optimize.exact.least_norm.grid import TIE_MAX_REGISTERS
from setupfix.optimize.exact.least_norm.shop import lower_bound_ratio
from setupfix.optimize.exact.session import Session
from setupfix.optimize.exact.triage.forced import Forced, forced_triage
from setupfix.optimize.exact.triage.model import (
    SLACK,
    KeptLevel,
    TriageRows,
    count_below,
    least_listed,
    listable,
    listed_triage,
    lp_starts,
)
from setupfix.optimize.exact.work import now, wall
from setupfix.optimize.problem import CorrectionProblem, OptimizeResult, Status, Stopped, TriageRecord

__all__ = ["Triaged", "triage", "triaged_result"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Triaged:
    """Outcome of :func:`triage`.

    Attributes
    ----------
    k : ndarray of shape (n,) or None
        The triaged correction in steps; None when not even the dimensions measured in tolerance
        can all be kept (a refusal: nothing is changed).
    kept : int
        Dimensions kept in tolerance (held ones included), N*.
    levels : tuple of KeptLevel
        Leximin levels proved: at most ``below`` kept margins under ``value`` (steps).
    complete : bool
        Every kept position is fixed by the levels (the whole leximin vector is proved).
    proved : bool
        Every stage was solved to optimality (the whole leximin vector and the least norm).
    why : str
        Which stage stopped and why (empty when proved).
    stages : tuple of str
        The stages completed, for the record.
    lower : float or None
        Certified lower bound on the least Σ c k² (None: not known), for a least norm not proved.
    calls : int
        Solver calls.
    kept_lp : tuple of (ndarray of bool, float) or None
        The kept set and the LP bound on its smallest margin with the held rows held, when known.
    """

    k: Array | None
    kept: int
    levels: tuple[KeptLevel, ...]
    complete: bool
    proved: bool
    why: str
    stages: tuple[str, ...]
    lower: float | None = None
    calls: int = 0
    kept_lp: tuple[npt.NDArray[np.bool_], float] | None = None


def _checked(
    model: LinearModel, left: float, start: Array | None, n: int, value: Callable[[Array], float], tol: float
) -> Solve:
    """Solve from ``start``; when HiGHS says optimal but its point's exact objective ``value(k)`` is not
    the one it reports (it sometimes hands the start back as optimal), solve again without the start."""
    res = model.solve(left, start)
    if (
        start is not None
        and res.status == "optimal"
        and res.x is not None
        and not abs(value(np.rint(res.x[:n])) - res.objective) <= tol
    ):
        res = model.solve(left, None)
    return res


def _status_word(status: str) -> str:
    return "time limit" if status == "time_limit" else f"HiGHS: {status}"


def triage(
    t: TriageRows, deadline: float, reserve: float, budget: float, start: Array, quantum: float, list_points: int
) -> Triaged:
    """Keep the most dimensions in tolerance without harm, then the leximin of their margins, then the least norm.

    Parameters
    ----------
    t : TriageRows
        Rows, dimensions and no-harm floors in grid steps.
    deadline : float
        ``now()`` value at which to stop.
    reserve : float
        Seconds kept for stage 3: no leximin level after the first starts with less left.
    budget : float
        Seconds the leximin levels may take: no level after the first starts once they have.
    start : ndarray of shape (n,)
        A grid point to start from (used when it keeps the held dimensions).
    quantum : float
        Margins within this many steps are ties (a level's multiplicity counts them).
    list_points : int
        Most grid points × rows listed instead of solving MILPs (``ExactSettings.triage_list_points``).
    """
    done: list[str] = []
    why = ""

    def left() -> float:
        return deadline - now()

    def first() -> float:  # stages 1 and 2 leave the reserve to stage 3
        return max(left() - reserve, min(left(), 0.05))

    zero = np.clip(np.zeros(t.n), t.kmin, t.kmax)
    if not t.hard_ok(zero):  # "no correction" is outside the box: nothing keeps the held ones for sure
        m1, _ = t.model(0, (), objective="count")
        res = m1.solve(left())
        if res.status == "infeasible":
            return Triaged(None, 0, (), False, True, "", ("the dimensions measured in tolerance cannot all be kept",))
    listed = listed_triage(t, quantum, list_points)
    if listed is not None:  # a small box: every grid point looked at
        k, kept = listed
        return Triaged(
            k,
            kept,
            (),
            True,
            True,
            "",
            (
                f"{kept} of {t.n_dims} dimensions kept in tolerance "
                f"({int(t.held.sum())} measured in tolerance held), "
                "leximin and least norm by listing the grid",
            ),
        )
    best = zero
    for k in [start, *(lp_starts(t, 0.4 * first()) if t.cand.size else [])]:
        if t.hard_ok(k) and t.kept(k).sum() > t.kept(best).sum():
            best = k

    # 1. most dimensions in tolerance, the held ones kept
    if t.cand.size:
        m1, _ = t.model(0, (), objective="count")
        res = _checked(
            m1,
            first(),
            t.start(best) if t.hard_ok(best) else None,
            t.n,
            lambda k: float(t.held.sum() - t.kept(k).sum()) if t.hard_ok(k) else np.inf,
            0.5,
        )
        if res.status == "infeasible":
            return Triaged(None, 0, (), False, True, "", ("the dimensions measured in tolerance cannot all be kept",))
        if res.x is not None:
            k = np.clip(np.rint(res.x[: t.n]), t.kmin, t.kmax)
            if t.hard_ok(k) and t.kept(k).sum() > t.kept(best).sum():
                best = k
        if res.status != "optimal" or t.kept(best).sum() < int(t.held.sum()) - res.objective - 0.5:
            stop = _status_word(res.status) if res.status != "optimal" else "HiGHS's point does not keep its count"
            why = f"most dimensions in tolerance: {stop}"  # the best count found goes on: never fewer, no harm
    kept = int(t.kept(best).sum())
    held = int(t.held.sum())
    if not why:
        done.append(f"{kept} of {t.n_dims} dimensions kept in tolerance ({held} measured in tolerance held)")

    # 2. leximin of the kept margins
    levels: tuple[KeptLevel, ...] = ()
    complete = t.positions(kept) == 0  # nothing kept has a margin: no level to find
    eps = quantum / 2
    t_lo = float(np.min(t.sorted_kept(best), initial=t.top))
    began = now()
    while not complete and not why:
        if levels and (left() < reserve or now() - began > budget):
            break
        m2, _ = t.model(kept, levels, objective="level", t_lo=min(t_lo, t.top))
        p = count_below(levels)
        v0 = float(t.sorted_kept(best)[p]) if t.sorted_kept(best).size > p else t.top

        def level_of(k: Array, p: int = p, levels: tuple[KeptLevel, ...] = levels) -> float:
            return -float(np.r_[t.sorted_kept(k), t.top][p]) if t.meets(k, kept, levels) else np.inf

        res = _checked(m2, first(), t.start(best, min(max(v0, t_lo), t.top)), t.n, level_of, quantum / 10)
        if res.x is not None:
            k = np.clip(np.rint(res.x[: t.n]), t.kmin, t.kmax)
            s = t.sorted_kept(k)
            if t.meets(k, kept, levels) and s.size > p and s[p] > v0:
                best, v0 = k, float(s[p])
        if res.status != "optimal" or v0 < -res.objective - quantum / 10:
            why = _status_word(res.status) if res.status != "optimal" else "HiGHS's point is below its level"
            why = f"leximin level {len(levels) + (0 if levels else 1)}: {why}"
            if not levels:  # level 1 stopped: the level its best point reaches holds in stage 3
                levels = (KeptLevel(float(np.r_[t.sorted_kept(best), t.top][0]), 0),)
            break
        value = v0
        levels = (*levels[:-1], KeptLevel(value, p)) if levels else (KeptLevel(value, 0),)
        # its multiplicity: the fewest kept margins within the quantum of it (p + 1 when the point has so few)
        below = int(np.sum(t.sorted_kept(best) < value + eps - SLACK))
        if below > p + 1:
            m3, _ = t.model(kept, levels, objective="multiplicity", at=value + eps)

            def count_of(k: Array, at: float = value + eps, levels: tuple[KeptLevel, ...] = levels) -> float:
                return float(np.sum(t.sorted_kept(k) < at - SLACK)) if t.meets(k, kept, levels) else np.inf

            res = _checked(m3, first(), t.start(best), t.n, count_of, 0.5)
            if res.x is not None:
                k = np.clip(np.rint(res.x[: t.n]), t.kmin, t.kmax)
                if t.meets(k, kept, levels) and np.sum(t.sorted_kept(k) < value + eps - SLACK) < below:
                    best = k
            below = int(np.sum(t.sorted_kept(best) < value + eps - SLACK))
            if res.status != "optimal" or below > round(res.objective):
                why = f"leximin level {len(levels)} multiplicity: " + (
                    _status_word(res.status) if res.status != "optimal" else "HiGHS's point does not reach its count"
                )
                break
        levels = (*levels, KeptLevel(value + eps, below))
        t_lo = value + eps
        done.append(f"leximin level {len(levels) - 1}: {below} kept margin(s) at {value:+.4g} steps")
        complete = below >= t.positions(kept)
    if not complete and not why:  # the levels' time is spent: the rest of the vector is not proved
        why = (
            f"leximin: time limit after level {len(levels) - 1} (the {count_below(levels)} smallest kept "
            "margins proved; the rest of the time is the least norm's)"
        )

    # 3. least Σ c k² holding N* and the levels
    n = t.n
    # every better point has c_i k_i² ≤ f(best): a box; chords near best, the others added lazily
    reach = np.floor(np.sqrt(float(np.sum(t.cost * best**2)) / t.cost) + 1e-9)
    lo_k, hi_k = np.maximum(t.kmin, -reach), np.minimum(t.kmax, reach)
    least = least_listed(t, lo_k, hi_k, kept, levels, list_points)
    if least is not None and t.meets(least, kept, levels):  # a small box: listed, ties to the smallest k
        done.append("least norm (listed)")
        return Triaged(least, kept, levels, complete, not why, why, tuple(done))
    chords = [{0, *range(max(int(abs(v)) - 2, 0), int(abs(v)) + 2)} for v in best]
    pairs = [(i, j) for i, js in enumerate(chords) for j in sorted(js)]
    m4, _ = t.model(kept, levels, objective="norm")
    m4.set_col_bounds(np.arange(n, dtype=np.int32), lo_k, hi_k)
    m4.prefer_proof()  # a feasible start is known: no RINS/RENS (they can overrun the limit)
    a_ch, rhs_ch = chord_rows(pairs, n, m4.n_cols)
    m4.add_rows(a_ch, np.full(rhs_ch.size, -INF), rhs_ch)
    out = lazy_chords(
        m4, n, chords, t.cost, t.kmin, t.kmax, best, lambda k: t.meets(k, kept, levels), t.start, deadline, integer=True
    )
    best = best if out.best is None else out.best
    if out.proved:
        done.append("least norm")
        best, tied = (
            smallest_tie(m4, n, chords, t.cost, best, lambda k: t.meets(k, kept, levels), t.start, deadline)
            if n <= TIE_MAX_REGISTERS
            else (best, False)
        )
        done.append("ties to the lexicographically smallest k" if tied else "the tie is not broken (limit or size)")
    if not out.proved:
        why = why or f"least norm: {out.why}"
    return Triaged(best, kept, levels, complete, not why, why, tuple(done))


def _kept_bound(t: TriageRows, keep: npt.NDArray[np.bool_], left: float) -> float | None:
    """LP bound (steps) on the smallest margin of the dimensions ``keep`` with the held ones held."""
    from scipy.sparse import csr_array, hstack

    rows = np.flatnonzero(keep[t.row_dim])
    if rows.size == 0:
        return None
    a = hstack(
        [
            csr_array(t.G[np.r_[rows, t.hard_rows]]),
            csr_array(np.r_[np.ones(rows.size), np.zeros(t.hard_rows.size)][:, None]),
        ]
    )
    model = LinearModel(
        np.r_[np.zeros(t.n), -1.0],
        a,
        np.full(rows.size + t.hard_rows.size, -INF),
        np.r_[t.g[rows], t.g[t.hard_rows] - t.hard_min],
        np.r_[t.kmin, -INF],
        np.r_[t.kmax, INF],
    )
    res = model.solve(max(left, 0.05))
    return -float(res.objective) if res.status == "optimal" else None


def triaged_result(
    problem: CorrectionProblem,
    session: Session,
    k_start: Array,
    path: list[str],
    notes: list[Note],
    calls: int,
    bound: float,
    name: str,
) -> OptimizeResult:
    """The triage stage: no correction brings every dimension into tolerance, so :func:`triage` decides.

    Everything the result states is read from the final answer: the dimensions given up (not held and
    predicted out of tolerance; ``given_up`` names every column of them, all of a zone's facets;
    ``triage.given_up`` each once with its margin, a zone's the circle's), δ, the bonus and the
    binding dimensions over the dimensions kept, the LP bound of those (``bound``; the whole problem's
    LP bound ``bound`` passed in stays in ``triage.lp_bound_all``), status and seconds of this call.
    """
    rows, clock = session.rows, session.clock
    ids, column_dim = model_dimensions(problem)  # a position zone is one dimension: kept or given up whole
    h = problem.resolution
    quantum = session.settings.quantum
    floor = dimension_floor(problem)
    t = TriageRows(rows.g_rows, rows.g, dimension_of_rows(problem), floor / h, rows.kmin, rows.kmax, rows.cost)
    reserve = session.settings.least_norm_share * session.time_limit
    forced = None
    settings = session.settings
    if settings.forced_triage and not listable(t, settings.triage_list_points):  # a small box is listed whole
        forced = forced_triage(session, t, k_start, now() + settings.forced_share * clock.left())
    if forced is not None:
        out = _forced_outcome(forced, t, quantum)
    else:
        out = triage(
            t,
            clock.deadline,
            reserve,
            settings.triage_leximin_share * session.time_limit,
            k_start,
            quantum,
            settings.triage_list_points,
        )
    clock.lap("triage")
    path.append("triage: " + ", ".join(out.stages) if out.stages else "triage")
    x = np.zeros(problem.n_registers)
    if out.k is None:
        message = (
            "not even the dimensions measured in tolerance can all be kept within the register limits: "
            "no correction is recommended"
        )
        notes.append(Note(message, kind="solver"))
        return make_result(
            problem,
            x,
            optimizer=name,
            evaluations=calls + 1,
            seconds=wall() - clock.wall_start,
            status="optimal",
            message=message,
            guard=False,
            notes=tuple(notes),
            triage=TriageRecord(refused=True, kept=0, held=int(t.held.sum()), lp_bound_all=bound),
            path="; ".join(path),
            stages=clock.stages,
        )
    x[problem.free] = out.k * h
    margins = dimension_margins(problem, x)  # a zone's: its polygon's, the least of its facets'
    held = np.isfinite(floor)
    gone = ~held & (margins < -1e-12)
    # every column of a dimension given up (all of a zone's facets): none of them counts in δ or the bound
    given_up = tuple(d for d, q in zip(problem.dimension_ids, column_dim, strict=True) if gone[q])
    names = tuple(d for d, g in zip(ids, gone, strict=True) if g)
    known = out.kept_lp is not None and np.array_equal(out.kept_lp[0], ~gone)
    kept_bound = out.kept_lp[1] if out.kept_lp is not None and known else _kept_bound(t, ~gone, clock.left())
    n_held = int(held.sum())
    message = (
        (
            f"no correction within the register limits brings every dimension into tolerance: "
            f"{len(names)} dimension(s) given up ({', '.join(names)}) need the NC program or the "
            f"process, not the setup; the {int((~gone).sum())} others (the {n_held} measured in tolerance "
            "among them) are kept in tolerance, centred level by level, with the smallest correction"
        )
        if names
        # never "0 dimension(s) given up ()": the triage's answer keeps every dimension
        else (
            f"the triage gave up no dimension: all {int((~gone).sum())} are kept in tolerance, centred "
            "level by level, with the smallest correction"
        )
    )
    notes.append(Note(message, kind="solver"))
    status: Status = "optimal"
    shown = problem.dimension_table(x)[5]  # a zone's margin as the circle's
    stages = dict(clock.stages)
    record = TriageRecord(
        refused=False,
        kept=int((~gone).sum()),
        held=n_held,
        lp_bound_all=bound,
        leximin_levels=sum(1 for s in out.stages if s.startswith("leximin level")),
        leximin_complete=out.complete,
        given_up={d: float(v) for d, v, g in zip(ids, shown, gone, strict=True) if g},
    )
    stopped: Stopped | None = None
    ratio: float | None = None
    if not out.proved:  # a stage stopped (the leximin levels' time included): never "optimal"
        status = "time_limit" if "time limit" in out.why else "solver_error"
        notes.append(Note(f"triage not proved ({out.why})", kind="solver"))
        message += f"; not proved ({out.why})"
        stopped = Stopped("triage", "time limit" if status == "time_limit" else out.why, detail=out.why)
        if out.lower is not None and not out.why.startswith("leximin"):
            ratio = lower_bound_ratio(float(np.sum(t.cost * out.k**2)), out.lower)
    evaluations = calls + (out.calls if out.calls else 2 + 2 * len(out.levels))
    return make_result(
        problem,
        x,
        optimizer=name,
        evaluations=evaluations,
        seconds=wall() - clock.wall_start,
        status=status,
        bound=None if kept_bound is None else kept_bound * h,
        message=message,
        guard=False,
        given_up=given_up,
        notes=tuple(notes),
        stopped=stopped,
        norm_ratio_max=ratio,
        triage=record,
        path="; ".join(path),
        stages=stages,
    )


def _forced_outcome(forced: Forced, t: TriageRows, quantum: float) -> Triaged:
    """:class:`Triaged` of the forced kept set: its leximin levels as triage levels, what stopped."""
    lex, least = forced.lex, forced.least
    eps = quantum / 2
    levels: list[KeptLevel] = []
    stages = [
        f"{int(forced.keep.sum())} of {t.n_dims} dimensions kept in tolerance ({int(t.held.sum())} "
        "measured in tolerance held; the others proved out of reach without harm)"
    ]
    below = 0
    for i, (value, count) in enumerate(lex.levels):
        below += count
        levels.append(KeptLevel(value + eps, below))
        stages.append(f"leximin level {i + 1}: {below} kept margin(s) at {value:+.4g} steps")
    complete = lex.stopped is None
    why = "" if complete else f"leximin: {lex.stopped.reason}" if lex.stopped is not None else ""
    if least.proved:
        stages.append("least norm")
    else:
        why = why or f"least norm: {least.why}"
    return Triaged(
        least.k,
        int(t.kept(least.k).sum()),
        tuple(levels),
        complete,
        not why,
        why,
        (*stages, *forced.path),
        least.lower,
        forced.calls,
        (forced.keep, forced.bound),
    )
