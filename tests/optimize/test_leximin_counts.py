"""The count MILPs of the leximin levels (:mod:`setupfix.optimize.exact.leximin.counts`) against brute force."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

import setupfix.optimize.exact.leximin.counts as countmod
from setupfix.optimize.exact.grid import TOL
from setupfix.optimize.exact.highs import LinearModel, Solve
from setupfix.optimize.exact.least_norm.grid import LeastNorm
from setupfix.optimize.exact.leximin.counts import CountLayout, CountRows
from setupfix.optimize.exact.leximin.result import Leximin
from setupfix.optimize.exact.session import GridRows, Session

from .test_leximin import CONFLICTS, NO_BRANCHES, brute_leximin, make, solved_steps
from .test_leximin_pins import box_points

Array = npt.NDArray[np.float64]
Ints = npt.NDArray[np.intp]
Mask = npt.NDArray[np.bool_]


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "seed", "kw"), CONFLICTS)
def test_each_count_equals_the_grid_count_and_fixes_only_what_the_lattice_decides(
    kind: str, seed: int, kw: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every count MILP's optimum is the most active dimensions with margin ≥ t + ε over the grid points
    that meet the floors, t0 and the blocks found so far (brute force); a dimension the model gives no
    binary (every row's lattice value at or above t0 is ≥ t) is ≥ t at every such point, and some have none."""
    seen: list[tuple[CountRows, list[tuple[float, int]], float, Mask, float]] = []
    original = countmod.count_model

    def model(
        rows: CountRows,
        blocks: list[tuple[float, int]],
        extra: int,
        question: tuple[float | None, int],
        objective: str,
        top: float,
        t_lo: float,
    ) -> tuple[LinearModel, CountLayout]:
        out, layout = original(rows, blocks, extra, question, objective, top, t_lo)
        if objective == "count":
            fixed = np.ones(rows.n_active, bool)
            fixed[layout.dims[-1]] = False
            solve = out.solve

            def recorded(limit: float, start: Array | None = None) -> Solve:
                res = solve(limit, start)
                if res.status == "optimal":
                    assert question[0] is not None
                    count = -float(res.objective) + layout.above_anyway(len(blocks))
                    seen.append((rows, list(blocks), float(question[0]), fixed, count))
                return res

            monkeypatch.setattr(out, "solve", recorded)
        return out, layout

    monkeypatch.setattr(countmod, "count_model", model)
    problem = make(kind, seed, kw)
    best, norm, _ = brute_leximin(problem)
    result, k, sorted_m = solved_steps(problem, settings=NO_BRANCHES)
    assert result.status == "optimal" and "the rest by counts" in result.path
    np.testing.assert_allclose(sorted_m, best, atol=1e-6)
    assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)
    assert seen
    n_fixed = 0
    for rows, blocks, t, fixed, count in seen:
        m_rows = rows.g[None, :] - box_points(rows) @ rows.g_rows.T
        m = np.full((m_rows.shape[0], rows.n_active), np.inf)
        for j, col in zip(np.flatnonzero(rows.act), rows.col, strict=True):
            m[:, col] = np.minimum(m[:, col], m_rows[:, j])
        ok = np.all(m_rows[:, rows.fix] >= rows.f[rows.fix] - TOL, axis=1) & np.all(
            m_rows[:, rows.act] >= rows.t0 - TOL, axis=1
        )
        for t_i, c_i in blocks:
            ok &= np.sum(m >= t_i - TOL, axis=1) >= c_i
        m = m[ok]
        assert count == pytest.approx(np.max(np.sum(m >= t - TOL, axis=1)))
        assert np.all(m[:, fixed] >= t - TOL)
        n_fixed += int(fixed.sum())
    assert n_fixed > 0


@pytest.mark.parametrize(("kind", "seed", "kw"), CONFLICTS)
def test_counts_stopped_give_the_least_norm_at_the_conflict_level_not_the_counts_point(
    kind: str, seed: int, kw: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """When the counts stop before their proof (here: no time for a second MILP), the answer is the least
    Σ c k² over every grid point with each dimension at its floor — the active ones at the conflict's level
    (brute force) — as where the levels stop, never the counts' unproved point."""
    import setupfix.optimize.exact.solve as exactmod
    from setupfix.optimize.exact.leximin.result import leximin_least_norm

    monkeypatch.setattr(countmod.CountRuns, "room", lambda self: self.calls == 0)
    captured: list[tuple[GridRows, Leximin, Ints]] = []
    original = leximin_least_norm

    def least(session: Session, lex: Leximin, row_dim: Ints, share: float) -> LeastNorm:
        captured.append((session.rows, lex, row_dim))
        return original(session, lex, row_dim, share)

    monkeypatch.setattr(exactmod, "leximin_least_norm", least)
    problem = make(kind, seed, kw)
    result, k, _ = solved_steps(problem, settings=NO_BRANCHES)
    assert result.status == "time_limit" and "the rest by counts" in result.path
    ((rows, lex, row_dim),) = captured
    assert lex.counts is None and lex.stopped is not None
    pts = box_points(rows)
    m_rows = rows.g[None, :] - pts @ rows.g_rows.T
    ok = np.all(m_rows >= lex.floors[row_dim][None, :] - 1e-9, axis=1)
    norms = (pts[ok] ** 2) @ rows.cost
    assert float(rows.cost @ k**2) == pytest.approx(norms.min(), abs=1e-9)


def test_a_run_starts_only_with_more_work_left_than_the_longest_took() -> None:
    from setupfix.optimize.exact.work import now

    runs = countmod.CountRuns(now() + 5.0)
    assert runs.room()
    runs.longest = 4.0
    assert runs.room()
    runs.longest = 6.0
    assert not runs.room()
    assert not countmod.CountRuns(now() - 1e-3).room()


def test_no_least_norm_milp_starts_when_a_count_milp_took_longer_than_what_is_left(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Counts proved, but the work left is less than the longest count MILP took: the chord MILP of the least
    norm is not started (HiGHS would run past the limit in its root's cut rounds); the answer says so."""
    solve = countmod.CountRuns.solve

    def slow(self: countmod.CountRuns, model: LinearModel) -> Solve:
        res = solve(self, model)
        self.longest = 1e6  # as if a count MILP had taken longer than any limit
        return res

    monkeypatch.setattr(countmod.CountRuns, "solve", slow)
    monkeypatch.setattr(countmod.CountRuns, "room", lambda self: True)
    monkeypatch.setattr(countmod, "lazy_chords", lambda *a, **k: pytest.fail("the chord MILP was started"))
    kind, seed, kw = CONFLICTS[0]
    result, _, _ = solved_steps(make(kind, seed, kw), settings=NO_BRANCHES)
    assert result.status == "time_limit"
    assert "less work left than a count MILP took" in result.path
    assert result.stopped is not None and result.stopped.reason == "work limit"
