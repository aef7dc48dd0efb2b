"""CRIPSO (Stryczek 2014): reproducibility, the grid, the budget, eq. 11, and gaps to the optimum."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.correction.synthetic import simulate_deviations
from setupfix.model import PartMeasurement, load_model
from setupfix.optimize import CorrectionProblem, Evaluator, get_optimizer
from setupfix.optimize import base as _base
from setupfix.optimize.heuristics.cripso import CRIPSO, coefficient_schedule, planula_position

Array = npt.NDArray[np.float64]

GUIDE_PINS = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


def make_problem(
    composite: npt.ArrayLike,
    deviation: npt.ArrayLike,
    half_tol: float,
    lb: npt.ArrayLike,
    ub: npt.ArrayLike,
    resolution: float = 0.001,
) -> CorrectionProblem:
    composite = np.asarray(composite, dtype=float)
    n, m = composite.shape
    return CorrectionProblem(
        composite=composite,
        deviation=np.asarray(deviation, dtype=float),
        lower=-np.broadcast_to(np.asarray(half_tol, dtype=float), (m,)).copy(),
        upper=np.broadcast_to(np.asarray(half_tol, dtype=float), (m,)).copy(),
        lb=np.asarray(lb, dtype=float),
        ub=np.asarray(ub, dtype=float),
        resolution=resolution,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def small_problem(seed: int) -> CorrectionProblem:
    """3 registers (31 grid steps each), 5 dimensions: 29,791 grid points in all."""
    rng = np.random.default_rng(seed)
    comp = rng.integers(-1, 2, size=(3, 5))
    comp[:, 0] = (1, 1, 0)  # every register acts on something
    comp[2, 1] = 1
    return make_problem(comp, np.round(rng.uniform(-0.04, 0.04, 5), 4), 0.05, [-0.015] * 3, [0.015] * 3)


def brute_force_f(problem: CorrectionProblem) -> tuple[float, float]:
    """Largest f = 10·f1 − f2 over the whole grid, and f1 there."""
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    x = np.array(list(itertools.product(*axes)), dtype=float) * problem.resolution
    f1, _, f = problem.evaluate(x)
    i = int(np.argmax(f))
    return float(f[i]), float(f1[i])


def guide_pins_problems(n_sets: int, seed: int) -> list[CorrectionProblem]:
    """The paper's example (8 WKS + 2 tools, 28 dimensions) on measurement sets of eqs. 12–13."""
    model = load_model(GUIDE_PINS / "model.toml")
    devs, _ = simulate_deviations(model, n_sets, w1=0.03, w2=0.02, seed=seed)
    m = len(model.dimensions)
    return [
        CorrectionProblem.from_part(
            model, PartMeasurement(part=f"s{i}", report="eqs. 12-13", timestamp=None, deviation=d, sources=("",) * m)
        )
        for i, d in enumerate(devs)
    ]


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch) -> list[Array]:
    """Every array CRIPSO hands to its Evaluator, in order."""
    calls: list[Array] = []

    class Recording(Evaluator):
        def __call__(self, x: Array) -> Array:
            calls.append(np.atleast_2d(np.array(x, dtype=float)))
            return super().__call__(x)

    monkeypatch.setattr(_base, "Evaluator", Recording)
    return calls


# -- reproducibility -------------------------------------------------------------------------------


def test_same_seed_gives_identical_run() -> None:
    problem = guide_pins_problems(1, seed=5)[0]
    a = CRIPSO(seed=11, n_solutions=2000).solve(problem)
    b = CRIPSO(seed=11, n_solutions=2000).solve(problem)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.history, b.history)


@pytest.mark.slow
def test_different_seeds_find_different_optima_of_a_tied_problem() -> None:
    # One dimension moved equally by three registers, 1 µm off centre: e_1, e_2 and e_3 (times −1 µm)
    # are the three optima of f (same f1, same norm); which one a run returns depends on the seed.
    problem = make_problem([[1.0], [1.0], [1.0]], [0.001], 0.05, [-0.01] * 3, [0.01] * 3)
    f_best, _ = brute_force_f(problem)
    found = set()
    for seed in range(12):
        result = CRIPSO(seed=seed, n_solutions=1000).solve(problem)
        assert result.fitness == pytest.approx(f_best, abs=1e-12)
        found.add(tuple(np.rint(result.x / problem.resolution).astype(int)))
    assert found <= {(-1, 0, 0), (0, -1, 0), (0, 0, -1)}
    assert len(found) >= 2


# -- grid, bounds, budget, history ------------------------------------------------------------------


@pytest.mark.parametrize(("n_solutions", "n_polyps"), [(1500, 100), (257, 16), (7, 10), (3, 2)])
def test_every_solution_on_grid_within_bounds_and_budget_exact(
    recorded: list[Array], n_solutions: int, n_polyps: int
) -> None:
    problem = make_problem(
        [[1, 0, 1], [1, -1, 0], [0, 1, 1], [2, 1, -1]],
        [0.03, -0.02, 0.011],
        0.04,
        lb=[-0.005, -0.02, 0.0, -0.01],
        ub=[0.013, 0.004, 0.0, 0.01],
    )
    result = CRIPSO(seed=2, n_solutions=n_solutions, n_polyps=n_polyps).solve(problem)
    x = np.concatenate(recorded)
    assert x.shape == (n_solutions, 4)
    assert result.evaluations == n_solutions
    np.testing.assert_array_equal(x, problem.snap(x))  # exactly on the grid, inside the bounds
    assert np.all(x >= problem.lb) and np.all(x <= problem.ub)
    assert np.all(x[:, 2] == 0.0)  # the fixed register
    if n_solutions > n_polyps:
        assert np.ptp(x[:, 0]) > 0 and np.ptp(x[:, 1]) > 0  # the free ones do move


def test_history_is_the_best_so_far_of_the_evaluated_sequence(recorded: list[Array]) -> None:
    problem = guide_pins_problems(1, seed=9)[0]
    result = CRIPSO(seed=4, n_solutions=3000).solve(problem)
    x = np.concatenate(recorded)
    f1, f2, f = problem.evaluate(x)
    running = np.maximum.accumulate(f)
    assert result.history is not None
    counts = result.history[:, 0].astype(int)
    np.testing.assert_array_equal(result.history[:, 3], running[counts - 1])
    improved = np.flatnonzero(f > np.r_[-np.inf, running[:-1]]) + 1
    assert set(improved) <= set(counts)  # every improvement is logged at its own solution number
    assert counts[-1] == 3000
    best = int(np.argmax(f))
    np.testing.assert_array_equal(result.x, x[best])
    assert result.margin_after == f1[best] and result.norm == f2[best]


# -- eq. 1 and eq. 11 ----------------------------------------------------------------------------------


def test_eq11_coefficient_schedule() -> None:
    c = coefficient_schedule(5000)
    assert c.shape == (5000,)
    assert c[0] == pytest.approx(np.cos(np.pi / 2 / 5000))
    assert c[2499] == pytest.approx(np.sqrt(0.5))  # L_i = L/2
    assert c[-1] == pytest.approx(0.0, abs=1e-15)  # last solution: no pull at all
    assert np.all(np.diff(c) < 0)


def test_eq1_planula_position() -> None:
    x = planula_position(
        np.array([0.0, 1.0]),
        np.array([2.0, 1.0]),
        np.array([4.0, 3.0]),
        np.array([-4.0, 0.0]),
        inertia=0.5,
        c1=0.5,
        c2=0.5,
        r1=np.array([1.0, 0.0]),
        r2=np.array([0.5, 1.0]),
    )
    np.testing.assert_allclose(x, [0.0 + 1.0 + 2.0 - 1.0, 1.0 + 0.0 + 0.0 - 0.5])


def reference_cripso(
    problem: CorrectionProblem, seed: int, n_polyps: int, n_solutions: int, inertia: float
) -> np.ndarray:
    """Slow, literal CRIPSO in grid units: eq. 1 via planula_position, f via problem.evaluate.

    Follows the decisions documented in setupfix.optimize.heuristics.cripso and its order of random draws.
    """
    rng = np.random.default_rng(seed)
    h, n, P, L = problem.resolution, problem.n_registers, n_polyps, n_solutions
    colony = rng.integers(problem.kmin, problem.kmax + 1, size=(P, n)).astype(float)
    first = rng.integers(0, P, L - P)
    second = (first + rng.integers(1, P, L - P)) % P
    r = rng.random((2, L - P, n))
    c = coefficient_schedule(L)
    x = list(colony)
    fx = list(problem.evaluate(colony * h)[2])
    plast = list(colony)  # no planula yet: no inertia
    pbest, fpb = list(colony), list(fx)
    gb = int(np.argmax(fx))
    out = list(colony)
    for t in range(L - P):
        i, j = int(first[t]), int(second[t])
        win, lose = (i, j) if fx[i] >= fx[j] else (j, i)
        if lose == gb:
            gb = win
        new = planula_position(
            x[win], plast[win], pbest[win], x[gb], inertia=inertia, c1=c[P + t], c2=c[P + t], r1=r[0, t], r2=r[1, t]
        )
        new = np.clip(np.rint(new), problem.kmin, problem.kmax)
        fn = float(problem.evaluate(new * h)[2])
        child_plast = 2 * new - x[win]  # inertia of the child: parent → settlement point
        plast[win] = new
        if fn > fpb[win]:
            pbest[win], fpb[win] = new, fn
        x[lose], fx[lose], plast[lose], pbest[lose], fpb[lose] = new, fn, child_plast, pbest[win], fpb[win]
        if fn > fx[gb]:
            gb = lose
        out.append(new)
    return np.array(out)


@pytest.mark.parametrize(
    ("seed", "inertia", "tied"), [(0, 0.75, False), (1, 0.75, False), (2, 0.4, False), (3, 0.75, True)]
)
def test_search_equals_a_literal_reference_of_the_paper(
    recorded: list[Array], seed: int, inertia: float, tied: bool
) -> None:
    # ``tied``: a small grid where planulae often land on their parents, so equal f (and the tie
    # rules of the tournament and of gbest) occur many times.
    problem = (
        make_problem([[1.0], [1.0], [1.0]], [0.001], 0.05, [-0.003] * 3, [0.003] * 3)
        if tied
        else guide_pins_problems(1, seed=seed + 40)[0]
    )
    CRIPSO(seed=seed, n_polyps=20, n_solutions=800, inertia=inertia).solve(problem)
    k = np.rint(np.concatenate(recorded) / problem.resolution)
    np.testing.assert_array_equal(k, reference_cripso(problem, seed, 20, 800, inertia))


@pytest.mark.parametrize("seed", range(5))
def test_last_planula_copies_its_parent(recorded: list[Array], seed: int) -> None:
    # With L = P + 1 the only planula is solution L: eq. 11 gives c1 = c2 = 0, and a polyp of the
    # initial colony has no inertia yet, so eq. 1 puts the planula exactly on the winner.  An off-by-
    # one in L_i (c = cos(π/2 · P/(P+1)) ≈ 0.14 here) moves it by several steps on this wide grid.
    problem = make_problem(np.eye(3), [0.05, -0.05, 0.0], 0.1, [-0.1] * 3, [0.1] * 3)
    CRIPSO(seed=seed, n_polyps=10, n_solutions=11).solve(problem)
    x = np.concatenate(recorded)
    f = problem.evaluate(x)[2]
    parents = np.flatnonzero(np.all(x[:10] == x[10], axis=1))
    assert parents.size >= 1
    assert f[parents].max() > np.sort(f[:10])[0]  # a winner, so never the colony's worst


def test_early_planulae_move() -> None:
    problem = make_problem(np.eye(3), [0.05, -0.05, 0.0], 0.1, [-0.1] * 3, [0.1] * 3)
    result = CRIPSO(seed=0, n_polyps=10, n_solutions=20).solve(problem)
    assert (
        result.history is not None and result.history[-1, 3] > result.history[0, 3]
    )  # something better than the random start


def test_rejects_a_colony_without_tournaments() -> None:
    with pytest.raises(ValueError, match="n_polyps"):
        CRIPSO(n_polyps=1).solve(small_problem(0))


# -- quality ----------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_small_problem_reaches_brute_force_optimum(seed: int) -> None:
    problem = small_problem(seed)
    f_best, f1_best = brute_force_f(problem)
    results = [CRIPSO(seed=s, n_solutions=3000).solve(problem) for s in range(3)]
    gaps_f = [f_best - r.fitness for r in results]
    assert min(gaps_f) == pytest.approx(0.0, abs=1e-12)
    assert np.median([f1_best - r.margin_after for r in results]) <= 0.001 + 1e-12


@pytest.mark.slow
def test_guide_pins_median_gap_to_exact_within_one_micrometre() -> None:
    gaps = []
    for problem in guide_pins_problems(5, seed=2014):
        exact = get_optimizer("exact").solve(problem)
        for seed in range(3):
            result = CRIPSO(seed=seed).solve(problem)
            assert result.evaluations == 5000
            gaps.append(exact.margin_after - result.margin_after)
    assert np.median(gaps) <= 0.001 + 1e-12
    assert max(gaps) <= 0.005  # 5 µm: a run stuck far from the optimum would show here
