"""Leximin centring on the register grid: every dimension as far inside its tolerance as the others allow.

Grid units as in :mod:`setupfix.optimize.exact.session`.  Each dimension q has the margin
``M_q(k) = min_{j ∈ q} (g_j − G_j k)`` (its rows: the two limits, eqs. 5–6; a circular position zone's
polygon facets, :func:`~setupfix.optimize.dimensions.dimension_of_rows`, so a zone is one dimension
and one position of the vector, fixed when all its facets are); the objective orders the
grid points by the vector of these margins sorted ascending, compared lexicographically
(the *leximin* order; margins within ``ε`` = half the input quantum are ties), and among
the leximin-optimal points takes the least Σ c_i k_i² (eq. 9), ties to the lexicographically
smallest k where a listing proves it.  Its first level is the paper's error budget δ = t*
of eq. 8 (:func:`~setupfix.optimize.exact.grid_optimum.grid_optimum`): leximin keeps the paper's
optimum and then centres every dimension that does not bind.

Levels (progressive filling, each level proved on the grid)
-----------------------------------------------------------
State: dimensions *fixed* with a floor v_q (every leximin-optimal point has M_q ≥ v_q and
no point of the current level set has M_q above v_q + ε), the others *active*.

1. Level value, from the current grid point k (:func:`raise_level`; small problems start each level from
   the grid climb's point where it is higher, :mod:`setupfix.optimize.exact.leximin.search`): its own
   level t = min of the active margins is proved when the rows rounded at t + ε hold no point of
   the box — a Farkas certificate by NNLS for small problems, else the duals of the level LP on the
   rounded rows (:meth:`~setupfix.optimize.exact.leximin.level.LevelModel.step`).  Otherwise the level
   LP's point, rounded, is the next k; the first level comes proved from the paper's stage, and the
   level LP's ascent and bracketed MILP (:meth:`~setupfix.optimize.exact.leximin.level.LevelModel.value`)
   remain for what the steps leave.
2. Saturation and pins (:mod:`setupfix.optimize.exact.leximin.pins`, checked in numpy): the proof's
   row weights show that a row's margin cannot rise above t + ε (saturated) or, on rounded rows,
   that G_j k takes one value on the whole level set (pinned).  Level sets only shrink, so pins
   are kept, and every integer row in the span of pinned rows is pinned too; a dimension all of
   whose rows are pinned is fixed at its margin at k, a saturated one at t.
3. If neither proof fixes a dimension, each dimension at t_i is tested alone: the rounded rows
   with its rows at t_i + ε (an LP, a feasibility MILP) either hold no grid point (saturated:
   fixed) or do.  If every one can rise alone but not all together (a *discrete conflict*: e.g.
   two dimensions moved oppositely by one register with the even split off the grid), the
   dimensions that can be the only one left at t_i (every other one above it at some grid
   point) each open a branch with that dimension fixed at t_i; the branches' leximin vectors are
   compared (a branch already below the best is dropped), tied branches all go to the least
   norm.  No such dimension: two or more must stay at t_i, and every leximin-optimal point has
   the fewest there — the pairs that can be the only two left open the branches instead.  None
   of those either (three or more), more than ``max_pair_tests`` pairs to test, or more than
   ``max_branches`` branches (:class:`~setupfix.optimize.exact.settings.ExactSettings`; a branch
   costs milliseconds on the paper's example, the counts seconds, ``bench/results/leximin_counts.txt``):
   the rest is decided by counts (:mod:`setupfix.optimize.exact.leximin.counts`, always correct,
   MILPs with binaries).

When every dimension is fixed, the leximin-optimal points are exactly the grid points with
M_q ≥ v_q for every q, and the least norm among them is stage 3
(:func:`~setupfix.optimize.exact.least_norm.grid.grid_least_norm`) on the rows shifted by the floors.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.leximin.counts import count_levels
from setupfix.optimize.exact.leximin.level import LevelModel, LevelValue
from setupfix.optimize.exact.leximin.pins import dim_all, dim_margins, excluded_alone, pinned_rows, span_closure
from setupfix.optimize.exact.leximin.result import Leximin, levels_of, leximin_least_norm, leximin_vector
from setupfix.optimize.exact.leximin.search import climb, climb_moves, lex_order
from setupfix.optimize.exact.session import Session
from setupfix.optimize.exact.work import now
from setupfix.optimize.problem import Stopped

__all__ = ["Leximin", "LevelSearch", "alone_sets", "leximin", "leximin_least_norm", "raise_level", "root_climb"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


class LevelSearch:
    """What one leximin search shares across its branches: the model, the deadline, the counters, and
    whether each branch starts with a grid climb (small problems: :mod:`setupfix.optimize.exact.leximin.search`)."""

    def __init__(self, session: Session, model: LevelModel, stage_end: float) -> None:
        self.session, self.model, self.stage_end = session, model, stage_end
        self.eps = session.settings.quantum / 2
        self.leaves = self.calls = 0
        self.climb = session.small and session.rows.n_free <= session.settings.climb_max_registers

    def climbed(self, k: Array, v: Array) -> Array:
        """The grid climb from k over the active dimensions (the fixed ones kept at their floors)."""
        m, rows = self.model, self.session.rows
        moves = rows.memo(("climb moves", m.order.tobytes()), lambda: climb_moves(rows.g_rows, m.order))
        return climb(
            rows.g_rows,
            rows.g,
            k,
            rows.kmin,
            rows.kmax,
            m.order,
            m.starts,
            v[m.dims],
            self.eps,
            self.stage_end,
            moves,
            self.session.settings.climb_scales,
        )

    def margins(self, k: Array) -> Array:
        """Each dimension's margin at k, shape (n_dims,)."""
        m = self.model
        return dim_margins(m.rows.g_rows, m.rows.g, k, m.order, m.starts, m.dims, m.n_dims)

    def all_rows(self, rows_mask: Mask) -> Mask:
        """Dimensions all of whose rows are in ``rows_mask``, shape (n_dims,)."""
        m = self.model
        return dim_all(rows_mask, m.order, m.starts, m.dims, m.n_dims)


def leximin(
    session: Session,
    row_dim: npt.NDArray[np.intp],
    n_dims: int,
    k_first: Array,
    t_first: float,
    first: LevelValue | None = None,
    floors: Array | None = None,
    stage_end: float | None = None,
    k_climb: Array | None = None,
) -> Leximin:
    """The leximin levels from a proved first level (t_first at the grid point k_first).

    Parameters
    ----------
    session : Session
        The solve (rows in grid units, clock, settings).
    row_dim : ndarray of int, shape (r,)
        Dimension (0 … n_dims − 1) of each row.
    n_dims : int
    k_first : ndarray of shape (n,); t_first : float
        A grid point and its proved max–min over the active dimensions (level 1, the paper's δ).
    first : LevelValue, optional
        The first level's LP certificate (its duals prove saturation at once).
    floors : ndarray of shape (n_dims,), optional
        Dimensions fixed before (finite floor v_q; NaN: active).  A caller that keeps a subset
        (the triage) passes floors for it and −inf for dimensions it leaves out.
    stage_end : float, optional
        ``now()`` at which the levels stop (default: the solve's deadline).
    k_climb : ndarray of shape (n,), optional
        The root's grid climb, when the caller climbed first (:func:`root_climb`).

    Returns
    -------
    Leximin
        With ``alternatives``: other branches of a discrete conflict whose leximin vectors tie with it
        (the least norm is taken over all of them).
    """
    stage_end = session.clock.deadline if stage_end is None else stage_end
    search, v, recomputed = _start(session, row_dim, n_dims, floors, k_first, stage_end)
    if recomputed:  # the first level was over dimensions no register moves: it is recomputed without them
        first = None
    if k_climb is None and search.climb:  # the root's climb, before the first level's dimensions are fixed
        k_climb = search.climbed(k_first, v)
    best = _fill(search, v, k_first, t_first, first, [], k_climb=k_climb)
    head = best[0]
    return Leximin(
        head.k, head.floors, head.levels, head.counts, head.stopped, head.path, search.calls, tuple(best[1:])
    )


def _start(
    session: Session, row_dim: npt.NDArray[np.intp], n_dims: int, floors: Array | None, k: Array, stage_end: float
) -> tuple[LevelSearch, Array, bool]:
    """The search and the floors it starts from: −inf for a dimension without rows, its margin for one no free
    register moves (fixed from the start; True when such a dimension was active)."""
    v = np.full(n_dims, np.nan) if floors is None else np.asarray(floors, dtype=float).copy()
    has_rows = np.zeros(n_dims, bool)
    has_rows[row_dim] = True
    v[~has_rows] = -np.inf
    constant = np.zeros(n_dims, bool)
    np.logical_or.at(constant, row_dim, True)
    np.logical_and.at(constant, row_dim, session.rows.zero)
    search = LevelSearch(session, LevelModel(session, row_dim, n_dims), stage_end)
    recompute = np.isnan(v) & constant
    if recompute.any():
        v[recompute] = search.margins(k)[recompute]
    return search, v, bool(recompute.any())


def root_climb(session: Session, row_dim: npt.NDArray[np.intp], n_dims: int, k: Array) -> Array | None:
    """The levels' first grid climb from k, over every dimension (None where the levels do not climb): run
    before the grid-optimum stage, its point is that stage's incumbent and the levels' start."""
    search, v, _ = _start(session, row_dim, n_dims, None, k, session.clock.deadline)
    return search.climbed(k, v) if search.climb else None


def _fill(
    search: LevelSearch,
    v: Array,
    k: Array,
    t: float,
    level: LevelValue | None,
    path: list[str],
    bound: Array | None = None,
    pinned: Mask | None = None,
    k_climb: Array | None = None,
) -> list[Leximin]:
    """Progressive filling from this state; the tied-best outcomes (branches of discrete conflicts).

    ``bound``: the sorted margins of the best branch so far; a branch whose settled margins (the
    fixed ones up to its current level) already fall below it is dropped (empty list).
    ``pinned``: rows whose G_j k is the same at every point of the current level set (level sets
    only shrink, so a pin stays true for the rest of this branch and its sub-branches).
    """
    model, eps, rows = search.model, search.eps, search.session.rows
    row_dim = model.row_dim
    v = v.copy()
    path = list(path)
    pinned = np.zeros(row_dim.size, bool) if pinned is None else pinned.copy()
    while True:
        active = np.isnan(v)
        if not active.any():
            break
        active_rows = active[row_dim]
        if now() >= search.stage_end:
            return [_stopped(search, v, k, path, "time limit")]
        if level is None and search.climb:  # the branch's climb (once): where higher, each level starts there
            k_climb = search.climbed(k, v) if k_climb is None else k_climb
            if k is not k_climb and model.level_of(k_climb, v) > model.level_of(k, v):
                k = k_climb
        k, t, sat, pin, stop, hint = raise_level(search, v, k, level, active_rows, path)
        if stop is not None:
            return [_stopped(search, v, k, path, stop)]
        # a row whose margin is proved within ε of t (integer: one lattice value) or pinned stays pinned, and
        # with it every row in their span: their dimensions' margins are the same at every point
        grown = pinned | pin | (sat & (rows.d > 0))
        if (grown & ~pinned).any():  # ``pinned`` is closed already: a new pin, a new closure
            pinned = rows.memo(
                ("span closure", grown.tobytes()),
                functools.partial(span_closure, rows.g_rows, rows.d, grown, model.key),
            )
        m_k = search.margins(k)
        fix_sat = np.zeros(v.size, bool)
        fix_sat[row_dim[sat]] = True
        fix_sat &= active
        fix_pin = search.all_rows(pinned) & active & ~fix_sat
        if not (fix_sat.any() or fix_pin.any()):  # each dimension at t: can it rise alone?
            for q in np.flatnonzero(active & (m_k <= t + eps)):
                rise = model.can_rise(v, int(q), t, eps, search.stage_end)
                search.calls += 1
                if rise is None:
                    return [_stopped(search, v, k, path, "time limit")]
                fix_sat[q] = not rise
            if not fix_sat.any():  # each can, not all together: a discrete conflict
                return _conflict(search, v, k, t, path, bound, pinned)
            path.append("leximin: saturation proved by the rounded rows one dimension at a time")
        v[fix_sat] = t
        v[fix_pin] = m_k[fix_pin]
        at_t = int(np.count_nonzero(fix_sat | (fix_pin & (m_k <= t + eps))))
        if at_t:
            path.append(f"leximin: {at_t} dimension(s) at {t:.4g} steps")
        if bound is not None and lex_order(np.sort(v[np.isfinite(v) & (v <= t + eps)]), bound, eps) < 0:
            return []
        if hint is not None and np.isnan(v).any():  # the proving LP's point, rounded: often the next level's
            k_hint, t_hint = model.round_best(hint, v)
            if t_hint > model.level_of(k, v) + 1e-9:
                k = k_hint
        level = None
    return [Leximin(k, v, levels_of(v), None, None, tuple(path), 0)]


def raise_level(
    search: LevelSearch, v: Array, k: Array, level: LevelValue | None, active_rows: Mask, path: list[str]
) -> tuple[Array, float, Mask, Mask, str | None, Array | None]:
    """The next level proved, from the point k: its point, t, saturated rows, pinned rows, and why it
    stopped (None: proved; else the best point found), and a continuous point to round for the next level.

    Cheapest first: the given level's LP weights (the first level's, from the paper's stage:
    no solve); one LP on the rounded rows at k's own level (:meth:`LevelModel.step`); else the
    level LP, its ascent and MILP (:meth:`LevelModel.value`) and the rounded rows' weights.
    """
    model, eps, rows = search.model, search.eps, search.session.rows
    if level is not None:
        sat, pin = pinned_rows(model.certify(level, v), active_rows, eps, rows.d)
        if sat.any() or pin.any():
            return level.k, level.t, sat, pin, None, None
    none = np.zeros(active_rows.size, bool)
    if rows.all_integer:  # one LP at k's own level (the first level: proved already)
        tries = search.session.settings.level_steps
        step = model.step(v, k if level is None else level.k, eps, search.stage_end, tries)
        search.calls += step.calls
        if step.stop is not None:
            return step.k, step.t, none, none, step.stop, None
        if step.proved and step.certificates is not None:
            sat, pin = pinned_rows(step.certificates, active_rows, eps, rows.d)
            return step.k, step.t, sat, pin, None, step.x
        k = step.k
    if level is None:
        level = model.value(v, k, search.stage_end)
        search.calls += level.calls
        path.extend(level.path)
        if level.stop is not None:
            return level.k, level.t, none, none, level.stop, None
        if level.certificates is not None:
            sat, _ = pinned_rows(model.certify(level, v), active_rows, eps, rows.d)
            _, pin = pinned_rows(level.certificates, active_rows, eps, rows.d)
            return level.k, level.t, sat, pin, None, None
    sat, pin = pinned_rows(model.certify(level, v), active_rows, eps, rows.d)
    if not (sat & active_rows).any() and rows.all_integer:  # the rounded rows' weights
        sat2, pin = pinned_rows(model.certify_rounded(level, v, search.stage_end), active_rows, eps, rows.d)
        sat |= sat2
        search.calls += 1
    return level.k, level.t, sat, pin, None, None


def _conflict(
    search: LevelSearch,
    v: Array,
    k: Array,
    t: float,
    path: list[str],
    bound: Array | None = None,
    pinned: Mask | None = None,
) -> list[Leximin]:
    """A discrete conflict at level t: one branch per dimension that can be the only one left at t
    (every other active dimension above t + ε at some grid point); if none can, one per pair that can
    be the only two left (every leximin-optimal point has the fewest dimensions at t); none, or too
    many branches: the counts decide (:mod:`setupfix.optimize.exact.leximin.counts`)."""
    starts = alone_sets(search, v, k, t, 1)
    if starts == []:
        starts = alone_sets(search, v, k, t, 2)
    if starts is None:
        return [_stopped(search, v, k, path, "time limit")]
    if not starts or search.leaves + len(starts) > search.session.settings.max_branches:
        return [_counts(search, v, k, t, path)]
    search.leaves += len(starts)
    best: list[Leximin] = []
    for dims, k_q in starts:
        v_q = v.copy()
        v_q[list(dims)] = t
        which = f"dimension {dims[0]}" if len(dims) == 1 else "dimensions " + ", ".join(map(str, dims))
        branch = _fill(
            search,
            v_q,
            k_q,
            t,
            None,
            [*path, f"leximin: discrete conflict at {t:.4g} steps, branch: {which} at it"],
            leximin_vector(best[0]) if best else bound,
            pinned,
        )
        if not branch:  # pruned: below the best branch
            continue
        if branch[0].stopped is not None:
            return branch
        order = 1 if not best else lex_order(leximin_vector(branch[0]), leximin_vector(best[0]), search.eps)
        if order > 0:
            best = branch
        elif order == 0:
            best = best + branch
    return best


def alone_sets(
    search: LevelSearch, v: Array, k: Array, t: float, together: int
) -> list[tuple[tuple[int, ...], Array]] | None:
    """The sets of ``together`` (1 or 2) active dimensions that can be the only ones left at t, each with
    a grid point; None: the limit stopped a test; [] also when there are more than
    ``ExactSettings.max_pair_tests`` pairs.

    One Farkas certificate excludes every dimension it does not lean on
    (:func:`~setupfix.optimize.exact.leximin.pins.excluded_alone`, integer rows): on a small problem from
    the whole system, beyond one from the rows near k (the level's point) only, whose NNLS costs a
    fraction of the whole's — at 180 × 2,000 it leaves 3 of 1,965 active dimensions to test alone,
    each test an LP (``bench/results/leximin_shop_trace.txt``).
    """
    model, eps, rows = search.model, search.eps, search.session.rows
    active = np.isnan(v)
    near = None if search.session.small else k  # small: the whole system (near rows first cost more there)
    out = (
        excluded_alone(rows, v[model.row_dim], model.row_dim, v.size, t, eps, together, near)
        if rows.all_integer
        else np.zeros((v.size,) * together, bool)
    )
    sets: list[tuple[int, ...]]
    if together == 1:
        sets = [(int(q),) for q in np.flatnonzero(active & ~out)]
    else:
        a, b = np.nonzero(np.triu(active[:, None] & active[None, :] & ~out, 1))
        sets = [(int(x), int(y)) for x, y in zip(a, b, strict=True)]
        if len(sets) > search.session.settings.max_pair_tests:
            return []
    starts: list[tuple[tuple[int, ...], Array]] = []
    for dims in sets:
        found = model.alone_at(v, dims, t, eps, search.stage_end)
        search.calls += 1
        if found is None:
            return None
        if found is not False:
            starts.append((dims, np.asarray(found, dtype=float)))
    return starts


def _stopped(search: LevelSearch, v: Array, k: Array, path: list[str], reason: str) -> Leximin:
    """The limit stopped the levels: the dimensions left get the best point's smallest margin as floor."""
    m_k = search.margins(k)
    active = np.isnan(v)
    v = v.copy()
    if active.any():
        v[active] = float(np.min(m_k[active]))
    return Leximin(k, v, levels_of(v), None, Stopped("leximin", reason), (*path, f"leximin: stopped ({reason})"), 0)


def _counts(search: LevelSearch, v: Array, k: Array, t: float, path: list[str]) -> Leximin:
    """The dimensions left are decided by counts (MILPs with binaries)."""
    path = [*path, f"leximin: discrete conflict at {t:.4g} steps; the rest by counts"]
    model = search.model
    out = count_levels(search.session, model.row_dim, model.n_dims, v, k, t, search.stage_end)
    search.calls += out.calls
    path.extend(out.path)
    if not out.proved:  # as where the levels stop: the least norm with every active margin ≥ t.  The blocks
        # proved so far would bring the counts' binaries into the least norm, whose chord MILP is nowhere near
        # its proof at shop scale: at 180 x 2,000 that gave the counts' point, ‖x‖ 0.91 mm, where the least
        # norm at t is 0.2 mm (bench/results/exact_scaling_leximin_20s.txt)
        return _stopped(search, v, k, path, out.why)
    vv = v.copy()
    vv[np.isnan(vv)] = t  # every active dimension has at least t (the counts say which have more)
    lex = tuple(sorted(list(levels_of(v)) + list(out.levels)))
    return Leximin(out.k, vv, lex, out, None, tuple(path), 0)
