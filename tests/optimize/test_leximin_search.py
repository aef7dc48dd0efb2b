"""The grid climb of the leximin levels (issue 22): a start point only — never worse, locally optimal, and
the proved answers are the same with it and without it."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.optimize.dimensions import dimension_of_rows
from setupfix.optimize.exact import ExactSettings
from setupfix.optimize.exact.leximin.search import climb, climb_moves, group_min
from setupfix.optimize.exact.lp_bound import margin_rows

from .test_exact import random_problem
from .test_leximin import CASES, CONFLICTS, brute_leximin, make, one_axis_problem, solved_steps

Array = npt.NDArray[np.float64]
Ints = npt.NDArray[np.intp]

EPS = 0.0005  # half the input quantum [steps], as the optimiser's ties


def grouped(problem: CorrectionProblem) -> tuple[Array, Array, Ints, Ints, Ints]:
    """The solver's rows and their grouping by dimension (order, starts, dimension of each group)."""
    g_rows, g = margin_rows(problem)
    row_dim = dimension_of_rows(problem)
    order = np.argsort(row_dim, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(row_dim[order]) != 0])
    return g_rows, g, order, starts, row_dim[order][starts]


def dim_margins(g_rows: Array, g: Array, order: Ints, starts: Ints, k: Array) -> Array:
    """Each group's margin at k, by plain loops (independent of the climb's reduceat)."""
    m = g - g_rows @ k
    return np.array([min(m[order[a:b]]) for a, b in itertools.pairwise([*starts, len(order)])])


def lex_better(a: np.ndarray, b: np.ndarray) -> bool:
    """Sorted a above sorted b in the leximin order (ties within ε)."""
    for x, y in zip(np.sort(a), np.sort(b), strict=True):
        if abs(x - y) > EPS:
            return bool(x > y)
    return False


def neighbours(n: int) -> Iterator[Array]:
    """Every move of one register by ±1 and of two registers by ±1 each (the climb's last scale)."""
    for i in range(n):
        for s in (1, -1):
            d = np.zeros(n)
            d[i] = s
            yield d
    for i, j in itertools.combinations(range(n), 2):
        for si, sj in itertools.product((1, -1), repeat=2):
            d = np.zeros(n)
            d[i], d[j] = si, sj
            yield d


PROBLEMS = (
    [("random", s, {"n": 4, "m": 7}) for s in range(6)]
    + [("axis", s, {}) for s in range(8)]
    + [("axis", s, {"n_wks": 3, "n_tools": 4, "m": 10, "limit": 8}) for s in range(8, 12)]
)


@pytest.mark.parametrize(("kind", "seed", "kw"), PROBLEMS)
def test_climb_is_never_worse_keeps_the_floors_and_stops_where_no_move_is_better(
    kind: str, seed: int, kw: dict[str, Any]
) -> None:
    problem = random_problem(seed, **kw) if kind == "random" else one_axis_problem(seed, **kw)
    g_rows, g, order, starts, _ = grouped(problem)
    free = problem.free
    kmin, kmax = problem.kmin[free].astype(float), problem.kmax[free].astype(float)
    rng = np.random.default_rng(seed)
    k0 = rng.integers(kmin, kmax + 1).astype(float)
    m0 = dim_margins(g_rows, g, order, starts, k0)
    floors = np.full(starts.size, np.nan)
    fixed = rng.random(starts.size) < 0.3  # some groups fixed at their margin at the start
    floors[fixed] = m0[fixed]
    k = climb(g_rows, g, k0, kmin, kmax, order, starts, floors, EPS)
    assert np.array_equal(k, np.rint(k)) and np.all(k >= kmin) and np.all(k <= kmax)
    m = dim_margins(g_rows, g, order, starts, k)
    assert np.all(m[fixed] >= floors[fixed] - 1e-9)
    active = ~fixed
    assert not lex_better(m0[active], m[active])  # never worse than the start
    for d in neighbours(k.size):  # a local optimum of the last scale's moves
        kk = k + d
        if np.any(kk < kmin) or np.any(kk > kmax):
            continue
        mm = dim_margins(g_rows, g, order, starts, kk)
        if np.all(mm[fixed] >= floors[fixed] - 1e-9):
            assert not lex_better(mm[active], m[active]), d


def test_climb_stops_at_its_deadline() -> None:
    problem = one_axis_problem(3)
    g_rows, g, order, starts, _ = grouped(problem)
    free = problem.free
    kmin, kmax = problem.kmin[free].astype(float), problem.kmax[free].astype(float)
    k0 = kmin.copy()  # a corner: some neighbour is better
    floors = np.full(starts.size, np.nan)
    assert not np.array_equal(climb(g_rows, g, k0, kmin, kmax, order, starts, floors, EPS), k0)
    assert np.array_equal(climb(g_rows, g, k0, kmin, kmax, order, starts, floors, EPS, deadline=0.0), k0)


def test_climb_without_an_active_dimension_returns_the_start() -> None:
    problem = one_axis_problem(0)
    g_rows, g, order, starts, _ = grouped(problem)
    free = problem.free
    k0 = np.zeros(int(free.sum()))
    k = climb(
        g_rows,
        g,
        k0,
        problem.kmin[free].astype(float),
        problem.kmax[free].astype(float),
        order,
        starts,
        np.full(starts.size, -np.inf),
        EPS,
    )
    assert k is k0


@pytest.mark.parametrize(("kind", "seed", "kw"), CASES[::3] + CONFLICTS)
def test_leximin_without_the_climb_equals_brute_force(
    kind: str, seed: int, kw: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The levels prove every level whatever point they start from: with no climb (the ascent by roundings,
    LPs and MILPs alone) the answer is brute force's, as with it."""
    problem = make(kind, seed, kw)
    best, norm, _ = brute_leximin(problem)
    if best[0] < 0:
        pytest.skip("out of reach: triage")
    with_climb = get_optimizer("exact", objective="leximin", time_limit=30.0).solve(problem)
    result, k, sorted_m = solved_steps(problem, settings=ExactSettings(climb_max_registers=0))
    assert result.status == "optimal", result.message
    np.testing.assert_allclose(sorted_m, best, atol=1e-6)
    assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)
    np.testing.assert_array_equal(result.x, with_climb.x)


@pytest.mark.parametrize("seed", range(4))
def test_climb_with_kept_moves_is_the_same_climb(seed: int) -> None:
    """The moves a caller keeps for one model (climb_moves) give the climb it would take without them."""
    problem = random_problem(seed)
    g_rows, g, order, starts, _ = grouped(problem)
    free = problem.free
    kmin, kmax = problem.kmin[free].astype(float), problem.kmax[free].astype(float)
    k0 = np.random.default_rng(seed).integers(kmin, kmax + 1).astype(float)
    floors = np.full(starts.size, np.nan)
    moves = climb_moves(g_rows, order)
    assert all(not a.flags.writeable for a in moves)
    np.testing.assert_array_equal(
        climb(g_rows, g, k0, kmin, kmax, order, starts, floors, EPS, moves=moves),
        climb(g_rows, g, k0, kmin, kmax, order, starts, floors, EPS),
    )


@pytest.mark.parametrize("sizes", [(2, 2, 2, 2), (1, 2, 3), (2, 1, 2), (5,), (2,)])
def test_group_min_is_the_least_of_each_group(sizes: tuple[int, ...]) -> None:
    """The strided two-row path and the general one give each group's least (numpy's reduceat as reference)."""
    rng = np.random.default_rng(len(sizes))
    m = rng.normal(size=(7, sum(sizes)))
    starts = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.intp)
    want = np.array([[row[a : a + n].min() for a, n in zip(starts, sizes, strict=True)] for row in m])
    np.testing.assert_array_equal(group_min(m, starts), want)
