"""Every level, pin and saturation the leximin search claims holds on the whole level set (brute force)."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

import setupfix.optimize.exact.leximin.levels as lexmod
from setupfix.optimize.exact.highs import LinearModel
from setupfix.optimize.exact.leximin.counts import CountRows
from setupfix.optimize.exact.leximin.level import LevelValue
from setupfix.optimize.exact.leximin.levels import LevelSearch
from setupfix.optimize.exact.leximin.pins import Certificates, dim_all, excluded_alone, pinned_rows, span_closure
from setupfix.optimize.exact.session import GridRows
from setupfix.optimize.exact.work import now

from .test_leximin import brute_leximin, guide_pins_window, one_axis_problem, solved_steps

Array = npt.NDArray[np.float64]
Ints = npt.NDArray[np.intp]
Mask = npt.NDArray[np.bool_]

EPS = 5e-4  # half the input quantum [steps]


def checked_levels(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Wrap the search's level proofs: each claim is checked against every grid point of the box."""
    grid: dict[str, Array] = {}
    seen: list[int] = []
    original = lexmod.raise_level

    def level(
        search: LevelSearch, v: Array, k: Array, given: LevelValue | None, active_rows: Mask, path: list[str]
    ) -> tuple[Array, float, Mask, Mask, str | None, Array | None]:
        out = original(search, v, k, given, active_rows, path)
        k_out, t, sat, pin, stop, _ = out
        if stop is not None:
            return out
        rows, model = search.session.rows, search.model
        if "k" not in grid:
            axes = [np.arange(lo, hi + 1) for lo, hi in zip(rows.kmin, rows.kmax, strict=True)]
            grid["k"] = np.array(list(itertools.product(*axes)), dtype=float)
        pts = grid["k"]
        m_rows = rows.g[None, :] - pts @ rows.g_rows.T
        m_dims = np.full((len(pts), model.n_dims), np.inf)
        for j, q in enumerate(model.row_dim):
            m_dims[:, q] = np.minimum(m_dims[:, q], m_rows[:, j])
        active, fixed = np.isnan(v), np.isfinite(v)
        base = np.all(m_dims[:, fixed] >= v[fixed] - 1e-9, axis=1)
        in_set = base & np.all(m_dims[:, active] >= t - 1e-9, axis=1)
        assert not np.any(base & np.all(m_dims[:, active] >= t + EPS, axis=1)), "a grid point is above the level"
        assert in_set[np.flatnonzero(np.all(pts == k_out, axis=1))[0]], "the level's point is not in its level set"
        values = pts[in_set] @ rows.g_rows.T
        assert np.all(np.ptp(values[:, pin], axis=0) < 1e-9), "a pinned row moves on the level set"
        assert np.all(m_rows[in_set][:, sat] <= t + EPS + 1e-9), "a saturated row rises on the level set"
        # the span closure of the pins is exact too
        closed = span_closure(rows.g_rows, rows.d, pin, model.key)
        assert np.all(np.ptp(values[:, closed], axis=0) < 1e-9), "a row in the span of pins moves"
        seen.append(int(pin.sum() + sat.sum()))
        return out

    monkeypatch.setattr(lexmod, "raise_level", level)
    return seen


@pytest.mark.slow
@pytest.mark.parametrize(
    ("kind", "seed"),
    [("window", 1), ("window", 2), ("window", 3), ("window", 5), ("axis", 5), ("axis", 37), ("axis", 3), ("axis", 11)],
)
def test_every_claim_of_the_levels_holds_on_the_level_set(
    kind: str, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    problem = guide_pins_window(seed) if kind == "window" else one_axis_problem(seed)
    best, norm, _ = brute_leximin(problem)
    if best[0] < 0:
        pytest.skip("triage")
    seen = checked_levels(monkeypatch)
    _, k, sorted_m = solved_steps(problem)
    assert seen and sum(seen) > 0  # the proofs did pin or saturate rows (the checks above ran on them)
    np.testing.assert_allclose(sorted_m, best, atol=1e-6)
    assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)


def test_a_rounding_error_with_a_tiny_weight_pins_nothing() -> None:
    """Weights of 1e-17 with a weighted sum of ~1e-16 (a rounding error): no room below d is claimed."""
    g_rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    rhs = np.array([0.0, 0.0, 3.0])
    y = np.array([0.5, 0.5, 1e-17])
    cert = Certificates(g_rows, np.array([-5.0, -5.0]), np.array([5.0, 5.0]), ((y, rhs, np.zeros(3), True),))
    _, pin = pinned_rows(cert, np.ones(3, bool), EPS, np.ones(3))
    # rows 0 and 1 add up to 0 (x0 ≤ 0 and −x0 ≤ 0: pinned); row 2's tiny weight proves nothing about it
    assert pin.tolist() == [True, True, False]


def test_span_closure_adds_exactly_the_rows_in_the_span() -> None:
    g_rows = np.array([[1.0, 1, 0], [0, 1, 1], [1, 2, 1], [1, 0, -1], [1, 0, 0], [-1, -2, -1]])
    key = g_rows @ np.array([3.0, 7.0, 11.0])
    closed = span_closure(g_rows, np.ones(6), np.array([True, True, False, False, False, False]), key)
    assert closed.tolist() == [True, True, True, True, False, True]
    row_dim = np.array([1, 1, 0, 0, 3, 3])  # dimension 2 has no row
    order = np.argsort(row_dim, kind="stable")
    assert dim_all(closed, order, np.array([0, 2, 4]), np.array([0, 1, 3]), 4).tolist() == [True, True, False, False]


def box_points(rows: GridRows | CountRows) -> Array:
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(rows.kmin, rows.kmax, strict=True)]
    return np.array(list(itertools.product(*axes)), dtype=float)


def box_dimension_margins(rows: GridRows, row_dim: Ints, n_dims: int, pts: Array) -> Array:
    m_rows = rows.g[None, :] - pts @ rows.g_rows.T
    m_dims = np.full((len(pts), n_dims), np.inf)
    for j, q in enumerate(row_dim):
        m_dims[:, q] = np.minimum(m_dims[:, q], m_rows[:, j])
    return m_dims


@pytest.mark.slow
@pytest.mark.parametrize("large", [False, True], ids=["small", "as-if-large"])
def test_a_dimension_excluded_from_a_conflict_is_never_alone_at_its_level(
    large: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The one Farkas certificate that spares the per-dimension tests of a discrete conflict: every
    dimension it excludes has no grid point with the other active ones above t + ε (brute force), and
    the search still finds the brute-force leximin — also on the path of problems too large for NNLS on
    the whole system (the certificate from the rows near the level's point only)."""
    if large:
        from setupfix.optimize.exact.session import Session

        monkeypatch.setattr(Session, "small", property(lambda self: False))
    claims: list[int] = []
    original = excluded_alone

    def checked(
        rows: GridRows,
        floors: Array,
        row_dim: Ints,
        n_dims: int,
        t: float,
        eps: float,
        together: int = 1,
        near: Array | None = None,
    ) -> Mask:
        out = original(rows, floors, row_dim, n_dims, t, eps, together, near)
        if together != 1:  # pairs: tests/optimize/test_leximin_pairs.py
            return out
        pts = box_points(rows)
        m = box_dimension_margins(rows, row_dim, n_dims, pts)
        v = np.full(n_dims, np.nan)
        v[row_dim] = floors
        active, fixed = np.isnan(v), np.isfinite(v)
        base = np.all(m[:, fixed] >= v[fixed] - 1e-9, axis=1)
        for q in np.flatnonzero(out):
            others = active.copy()
            others[q] = False
            alone = base & (m[:, q] >= t - 1e-9) & np.all(m[:, others] >= t + eps - 1e-9, axis=1)
            assert not alone.any(), f"dimension {q} is alone at {t} at a grid point"
        claims.append(int(out.sum()))
        return out

    monkeypatch.setattr(lexmod, "excluded_alone", checked)
    for kind, seed in [("window", s) for s in range(1, 6)] + [("axis", s) for s in range(3, 40, 4)]:
        problem = guide_pins_window(seed) if kind == "window" else one_axis_problem(seed)
        best, norm, _ = brute_leximin(problem)
        if best[0] < 0:
            continue
        _, k, sorted_m = solved_steps(problem)
        np.testing.assert_allclose(sorted_m, best, atol=1e-6)
        assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)
    assert claims and sum(claims) > 0  # conflicts were met and the certificate excluded dimensions


@pytest.mark.parametrize("seed", range(20))
def test_farkas_weights_or_a_point_match_the_grid(seed: int) -> None:
    """NNLS on random rounded rows: weights only when no grid point meets them (brute force), else a
    continuous point of the rows; a floor/ceil rounding that meets them is a real grid point."""
    from setupfix.optimize.exact.farkas import farkas_or_point
    from setupfix.optimize.exact.leximin.pins import meeting_rounding
    from setupfix.optimize.exact.session import GridRows

    rng = np.random.default_rng(seed)
    g_rows = rng.integers(-2, 3, size=(8, 3)).astype(float)
    g = rng.uniform(-2.0, 4.0, 8)
    rows = GridRows(g_rows, g, np.full(3, -3.0), np.full(3, 3.0), np.ones(3))
    b = np.floor(g)
    pts = box_points(rows)
    feasible = np.all(pts @ g_rows.T <= b + 1e-9, axis=1)
    y, x = farkas_or_point(rows, b)
    if y is not None:
        assert not feasible.any()
    if x is not None:
        assert np.all(g_rows @ x <= b + 1e-6) and np.all(np.abs(x) <= 3 + 1e-9)
        k = meeting_rounding(rows, x, g - b)
        if k is not None:
            assert np.all(g - g_rows @ k >= g - b - 1e-9) and np.all(np.abs(k - x) < 1)
    assert y is not None or x is not None or not feasible.any()


@pytest.mark.parametrize("tight", [2.0, 1e9])
def test_point_above_answers_as_the_grid_does(tight: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """A point that meets the floors, or False exactly when no grid point of the box does (brute force) —
    with the first MILP on the rows near the LP's vertex (tight_slack) and with all rows at once."""
    import setupfix.optimize.exact.leximin.pins as pins
    from setupfix.optimize.exact.session import Session
    from setupfix.optimize.exact.settings import ExactSettings

    sizes: list[tuple[int, int]] = []

    class Counted(LinearModel):
        def __init__(self, c: Array, a: object, *args: Any, **kw: Any) -> None:
            super().__init__(c, a, *args, **kw)
            sizes.append((self.n_rows, self.n_cols))

    monkeypatch.setattr(pins, "LinearModel", Counted)
    answers = {"point": 0, "none": 0}
    tight_first = 0  # tests whose first MILP had fewer rows than the test's floors
    for seed in range(150):
        rng = np.random.default_rng(seed)
        n, r = 4, 9
        g_rows = rng.integers(-2, 3, size=(r, n)).astype(float)
        g_rows[rng.random((r, n)) < 0.4] = 0.0
        rows = GridRows(g_rows, rng.uniform(-2, 6, r).round(1), np.full(n, -3.0), np.full(n, 3.0), np.ones(n))
        session = Session(rows, ExactSettings(tight_slack=tight))
        f = np.where(rng.random(r) < 0.8, rng.uniform(-1, 3, r).round(1), -np.inf)
        pts = box_points(rows)
        fin = np.isfinite(f)
        meets = np.all((rows.g - pts @ g_rows.T)[:, fin] >= f[fin] - 1e-9, axis=1)
        sizes.clear()
        got = pins.point_above(session, f, now() + 1e9)
        tight_first += bool(sizes) and sizes[0][0] < int(np.isfinite(f).sum())
        if meets.any():
            assert got is not False and got is not None, seed
            assert np.all((rows.g - g_rows @ got)[fin] >= f[fin] - 1e-9), seed
            answers["point"] += 1
        else:
            assert got is False, seed
            answers["none"] += 1
    assert answers["point"] > 20 and answers["none"] > 20
    assert (tight_first > 0) == (tight < 1e9)  # the tight-row MILP ran, and only where asked for


def test_meeting_rounding_is_the_first_floor_ceil_choice_that_meets_the_floors() -> None:
    """Against every floor/ceil choice listed in the same order (the lowest bits first), on 30 random cases
    of both outcomes: the same point, or None exactly when no choice meets the floors; rows without a
    floor (−inf) never refuse one."""
    from setupfix.optimize.exact.leximin.pins import meeting_rounding
    from setupfix.optimize.exact.session import GridRows

    outcomes = []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        n, r = 6, 14
        g_rows = rng.integers(-2, 3, size=(r, n)).astype(float)
        rows = GridRows(g_rows, rng.uniform(-3.0, 3.0, r), np.full(n, -4.0), np.full(n, 4.0), np.ones(n))
        x = rng.uniform(-3.5, 3.5, n)
        x[: seed % 3] = np.round(x[: seed % 3])  # some coordinates already integer
        frac = np.flatnonzero(np.abs(x - np.rint(x)) > 1e-6)
        some = np.rint(x)
        some[frac] = np.floor(x[frac]) + rng.integers(0, 2, frac.size)  # one choice: its margins, less a little
        f = rows.g - g_rows @ some - rng.uniform(0.0, 0.5, r)
        if seed % 2:  # raise a few floors: often no choice meets them any more
            f[rng.integers(0, r, 3)] += 1.0
        f[rng.random(r) < 0.3] = -np.inf
        found = None
        for bits in range(1 << frac.size):
            cand = np.rint(x)
            cand[frac] = np.floor(x[frac]) + ((bits >> np.arange(frac.size)) & 1)
            if np.all(rows.g - g_rows @ cand >= f - 1e-9):
                found = cand
                break
        got = meeting_rounding(rows, x, f)
        if found is None:
            assert got is None, seed
        else:
            np.testing.assert_array_equal(got, found)
        outcomes.append(found is not None)
    assert any(outcomes) and not all(outcomes)
