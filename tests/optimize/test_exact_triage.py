"""Triage and register costs of the exact optimiser, against brute force over whole small grids."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.inputs.cycles import load_parts
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.optimize.exact import ExactSettings

from .test_exact import random_problem
from .test_exact_robust import GUIDE_PINS

#: Seconds each solve compared with brute force or an independent MILP may take: the answers are the
#: subject, and a loaded box can stop a 2 s solve (a stopped solve says so; other tests check that).
SOLVE_LIMIT = 60.0

Array = npt.NDArray[np.float64]


def grid_points(problem: CorrectionProblem) -> np.ndarray:
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    return np.array(list(itertools.product(*axes)), dtype=float) * problem.resolution


def brute_triage(problem: CorrectionProblem) -> tuple[int, np.ndarray, float, np.ndarray]:
    """Every grid point: the most dimensions in tolerance with every dimension measured in tolerance
    kept in, then the leximin of the kept margins (sorted, compared lexicographically), then the least
    weighted norm, then the lexicographically smallest k.

    Returns the count, the sorted kept margins, the norm and the set of optimal points (steps).
    """
    x = grid_points(problem)
    margins = problem.margins(x)
    floor = problem.held_floor
    held = np.isfinite(floor)
    no_harm = np.all(margins[:, held] >= floor[held] - 1e-12, axis=1)
    kept = held | (margins >= -1e-12)
    count = np.where(no_harm, kept.sum(axis=1), -1)
    best = count.max()
    rows = np.flatnonzero(count == best)
    keys = [tuple(np.round(np.sort(margins[i][kept[i]]), 9)) for i in rows]
    top = max(keys)
    rows = np.array([i for i, key in zip(rows, keys, strict=True) if key == top])
    norms = np.sum(problem.cost * x[rows] ** 2, axis=1)
    least = rows[norms <= norms.min() + 1e-15]
    return int(best), np.array(top), float(np.sqrt(norms.min())), np.rint(x[least] / problem.resolution)


def check_triage(problem: CorrectionProblem, result: OptimizeResult) -> None:
    count, sorted_kept, norm, points = brute_triage(problem)
    margins = problem.margins(result.x)
    held = np.isfinite(problem.held_floor)
    kept = held | (margins >= -1e-12)
    assert result.status == "optimal"
    assert np.all(margins[held] >= problem.held_floor[held] - 1e-12)  # no harm
    assert kept.sum() == count
    assert set(result.given_up) == {d for d, k in zip(problem.dimension_ids, kept, strict=True) if not k}
    assert np.sort(margins[kept]) == pytest.approx(sorted_kept, abs=1e-9)  # the whole leximin vector
    assert np.sqrt(np.sum(problem.cost * result.x**2)) == pytest.approx(norm, abs=1e-12)
    assert tuple(np.rint(result.x / problem.resolution)) == min(map(tuple, points))  # ties: the smallest k
    assert result.margin_after == pytest.approx(sorted_kept[0], abs=1e-9)  # δ over the kept dimensions
    assert result.bound is not None and result.bound >= result.margin_after - 1e-9
    assert "given up" in result.message and "NC program or the process" in result.message
    assert result.given_up and f"{len(result.given_up)} dimension(s) given up (" in result.message  # never 0, ()


#: Every way of the triage: listing a small box; the forced kept set (listing switched off), which falls
#: back to the MILPs where the kept set is not forced; the MILPs alone (both switched off).
TRIAGE_PATHS = {
    "listed": ExactSettings(),
    "forced": ExactSettings(triage_list_points=0),
    "milp": ExactSettings(triage_list_points=0, forced_triage=False),
}


@pytest.fixture(params=["listed", "forced", "milp"])
def path(request: pytest.FixtureRequest) -> str:
    """The name of one way of the triage (:data:`TRIAGE_PATHS`)."""
    return str(request.param)


@pytest.mark.parametrize("seed", range(24))
def test_triage_equals_brute_force(seed: int, path: str) -> None:
    problem = random_problem(seed, n=3, m=7, limit_steps=2, spread=0.3)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem)
    if brute_triage(problem)[0] == len(problem.dimension_ids):  # everything can be kept: no triage
        assert result.given_up == ()
        return
    check_triage(problem, result)


@pytest.mark.parametrize("seed", [13, 25, 27, 33, 40, 55, 3, 4])
def test_triage_ties_go_to_the_smallest_correction_on_every_path(seed: int, path: str) -> None:
    """Two registers that move the same dimensions alike: an odd total step splits two ways with the same
    norm (seeds 13 … 55 tied, and the MILP path picked the larger one before its tie-break)."""
    import dataclasses

    base = random_problem(seed, n=3, m=7, limit_steps=3, spread=0.3)
    composite = base.composite.copy()
    composite[1] = composite[0]
    problem = dataclasses.replace(base, composite=composite)
    if brute_triage(problem)[0] == len(problem.dimension_ids):
        pytest.skip("everything can be kept: no triage")
    check_triage(problem, get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem))


@pytest.mark.parametrize("seed", range(12))
def test_triage_with_costs_fixed_registers_and_guard_floor_equals_brute_force(seed: int, path: str) -> None:
    """Weighted norm, a fixed register, and a no-harm floor below 0 (a guard band: kept inside the real limits)."""
    import dataclasses

    rng = np.random.default_rng(900 + seed)
    base = random_problem(300 + seed, n=4, m=8, limit_steps=2, spread=0.25, fixed=(3,))
    floor = np.where(rng.random(8) < 0.5, -rng.uniform(0.0, 0.02, 8), base.held_floor)
    inside = (base.deviation >= base.lower) & (base.deviation <= base.upper)
    floor = np.where(inside, np.minimum(floor, 0.0), -np.inf)
    problem = dataclasses.replace(base, cost=rng.uniform(0.5, 3.0, 4), floor=floor)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem)
    if brute_triage(problem)[0] == len(problem.dimension_ids) and result.margin_after >= 0:
        return
    if not result.given_up and result.margin_after >= 0:
        return
    check_triage(problem, result)


def milp_triage(problem: CorrectionProblem) -> tuple[int, np.ndarray, float]:
    """An independent formulation with scipy.optimize.milp: one-hot grid values per register
    (k_i = Σ v·b_iv, k_i² = Σ v²·b_iv exactly), binaries "kept" per dimension, and the leximin as
    the lexicographic maximum of the cumulative ordered sums θ_l = max_r l·r − Σ_q max(r − m'_q, 0)
    (Ogryczak's ordered outcomes) over m'_q = kept margin (a large value when given up)."""
    from scipy.optimize import Bounds, LinearConstraint, milp

    h = problem.resolution
    n, m = problem.n_registers, len(problem.dimension_ids)
    values = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    nb = sum(v.size for v in values)
    # columns: b (nb) | z (m) | mp (m) | then per l = 1…m its own r_l and d_l (m)
    width = nb + 2 * m + m * (1 + m)
    iz, imp = nb, nb + m

    def ir(ell: int) -> int:
        return nb + 2 * m + (ell - 1) * (1 + m)

    def idd(ell: int) -> int:
        return ir(ell) + 1

    kx = np.zeros((n, width))  # k_i as a row over the columns
    start = 0
    for i, v in enumerate(values):
        kx[i, start : start + v.size] = v
        start += v.size
    one_hot = np.zeros((n, width))
    start = 0
    for i, v in enumerate(values):
        one_hot[i, start : start + v.size] = 1
        start += v.size
    comp = problem.composite
    dev = problem.deviation / h
    up, lo = problem.upper / h, problem.lower / h
    pred = comp.T @ kx  # predicted − deviation, in steps, rows (m, width)
    big = 1e3
    floor = problem.held_floor / h
    held = np.isfinite(floor)
    cons = [LinearConstraint(one_hot, 1, 1)]
    for q in range(m):
        for sign, limit in ((1.0, up[q]), (-1.0, -lo[q])):
            if not np.isfinite(limit):
                continue
            margin = -sign * pred[q]  # margin = limit − sign·(dev + pred) = (limit − sign·dev) + margin row
            const = limit - sign * dev[q]
            row = margin.copy()
            if held[q]:
                cons.append(LinearConstraint(row[None], floor[q] - const, np.inf))  # hard no-harm row
                row_z = row.copy()
            else:
                row_z = row.copy()
                row_z[iz + q] = -big
                cons.append(LinearConstraint(row_z[None], -const - big, np.inf))  # margin ≥ 0 when kept
            row_mp = -row.copy()
            row_mp[imp + q] = 1.0
            if not held[q]:
                row_mp[iz + q] = big
            cons.append(LinearConstraint(row_mp[None], -np.inf, const + big * (0 if held[q] else 1)))
    for q in range(m):
        if held[q]:
            zrow = np.zeros(width)
            zrow[iz + q] = 1
            cons.append(LinearConstraint(zrow[None], 1, 1))
    # d_lq ≥ r_l − m'_q
    for ell in range(1, m + 1):
        for q in range(m):
            row = np.zeros(width)
            row[idd(ell) + q], row[ir(ell)], row[imp + q] = 1, -1, 1
            cons.append(LinearConstraint(row[None], 0, np.inf))
    integrality = np.r_[np.ones(nb + m), np.zeros(width - nb - m)]
    lb = np.r_[np.zeros(nb + m), np.full(m, -big), np.tile(np.r_[-big, np.zeros(m)], m)]
    ub = np.r_[np.ones(nb + m), np.full(m, big / 2), np.tile(np.r_[big, np.full(m, 2 * big)], m)]
    bounds = Bounds(lb, ub)

    def solve(c: Array, extra: list[LinearConstraint]) -> Any:
        res = milp(
            c,
            constraints=cons + extra,
            integrality=integrality,
            bounds=bounds,
            options={"mip_rel_gap": 0, "presolve": True},
        )
        assert res.status == 0, res.message
        return res

    zsum = np.zeros(width)
    zsum[iz : iz + m] = 1
    c = np.zeros(width)
    c[iz : iz + m] = -1
    count = round(-solve(c, []).fun)
    fixed = [LinearConstraint(zsum[None], count, np.inf)]
    thetas = []
    for ell in range(1, count + 1):
        c = np.zeros(width)
        c[ir(ell)], c[idd(ell) : idd(ell) + m] = -ell, 1
        theta = -solve(c, fixed).fun
        thetas.append(theta)
        row = np.zeros(width)
        row[ir(ell)], row[idd(ell) : idd(ell) + m] = ell, -1
        fixed.append(LinearConstraint(row[None], theta - 1e-7, np.inf))
    cost = np.zeros(width)
    start = 0
    for i, v in enumerate(values):
        cost[start : start + v.size] = problem.cost[i] * v.astype(float) ** 2
        start += v.size
    norm = solve(cost, fixed).fun
    sorted_kept = np.diff(np.r_[0.0, thetas]) * h
    return count, sorted_kept, float(np.sqrt(norm) * h)


@pytest.mark.parametrize("seed", range(10))
def test_triage_equals_an_independent_milp(seed: int, path: str) -> None:
    problem = random_problem(700 + seed, n=3, m=6, limit_steps=3, spread=0.3)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem)
    if not result.given_up:
        pytest.skip("every dimension can be kept: no triage")
    count, sorted_kept, norm = milp_triage(problem)
    margins = problem.margins(result.x)
    kept = np.array([d not in result.given_up for d in problem.dimension_ids])
    assert kept.sum() == count
    assert np.sort(margins[kept]) == pytest.approx(sorted_kept, abs=1e-7)
    assert np.sqrt(np.sum(problem.cost * result.x**2)) == pytest.approx(norm, abs=1e-7)


def test_one_gross_error_does_not_push_good_dimensions_out(guide_pins_model: ProcessModel) -> None:
    """Issue 13: P1 D1 at −0.25 mm on ±0.1 must not move P1 D2 (−0.029, in tolerance) out."""
    (part,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    dev = part.deviation.copy()
    ids = [d.id for d in guide_pins_model.dimensions]
    dev[0] = -0.25
    problem = CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, dev, part.sources))
    result = get_optimizer("exact", objective="paper").solve(problem)
    margins = problem.margins(result.x)
    assert result.given_up == (ids[0],)
    assert np.all(np.delete(margins, 0) >= 0)
    assert result.status == "optimal"


def test_a_costlier_register_moves_less_among_equally_good_corrections() -> None:
    """Two registers that move the dimensions alike: the cheap one takes the shift."""
    comp = np.array([[1.0, 1.0, -1.0], [1.0, 1.0, -1.0], [0.0, 1.0, 1.0]])
    base: dict[str, Any] = dict(
        composite=comp,
        deviation=np.array([0.03, 0.03, -0.03]),
        lower=np.full(3, -0.05),
        upper=np.full(3, 0.05),
        lb=np.full(3, -0.05),
        ub=np.full(3, 0.05),
        resolution=0.001,
        register_ids=("G54", "H5", "H6"),
        dimension_ids=("D1", "D2", "D3"),
    )
    plain = get_optimizer("exact", objective="paper").solve(CorrectionProblem(**base))
    paper = get_optimizer("exact", objective="paper")
    tool_dear = paper.solve(CorrectionProblem(**base, cost=np.array([1.0, 10.0, 1.0])))
    wks_dear = paper.solve(CorrectionProblem(**base, cost=np.array([10.0, 1.0, 1.0])))
    assert plain.margin_after == tool_dear.margin_after == wks_dear.margin_after
    assert abs(tool_dear.x[1]) < abs(plain.x[1]) and abs(tool_dear.x[0]) > abs(plain.x[0])
    assert abs(wks_dear.x[0]) < abs(plain.x[0])


@pytest.mark.parametrize("seed", range(6))
def test_weighted_least_norm_equals_brute_force(seed: int) -> None:
    problem = random_problem(200 + seed, n=4, m=6, limit_steps=4)
    cost = np.random.default_rng(seed).uniform(0.2, 5.0, problem.n_registers)
    weighted = CorrectionProblem(
        problem.composite,
        problem.deviation,
        problem.lower,
        problem.upper,
        problem.lb,
        problem.ub,
        problem.resolution,
        problem.register_ids,
        problem.dimension_ids,
        cost=cost,
    )
    result = get_optimizer("exact", objective="paper").solve(weighted)
    x = grid_points(weighted)
    f1, _, _ = weighted.evaluate(x)
    best = f1.max()
    if best < 0:
        pytest.skip("out of reach: triage case")
    norm = np.sqrt(np.sum(cost * x[f1 >= best - 1e-12] ** 2, axis=1)).min()
    assert result.margin_after == pytest.approx(best, abs=1e-12)
    assert np.sqrt(np.sum(cost * result.x**2)) == pytest.approx(norm, abs=1e-12)


@pytest.mark.parametrize("cost", [np.array([1.0, 0.0, 1.0]), np.array([1.0, np.inf, 1.0]), np.ones(2)])
def test_register_cost_must_be_positive_and_finite(cost: Array) -> None:
    from setupfix.core.errors import ParameterError

    problem = random_problem(0, n=3)
    with pytest.raises(ParameterError, match="register cost"):
        CorrectionProblem(
            problem.composite,
            problem.deviation,
            problem.lower,
            problem.upper,
            problem.lb,
            problem.ub,
            problem.resolution,
            problem.register_ids,
            problem.dimension_ids,
            cost=cost,
        )


def test_metaheuristics_give_nothing_up() -> None:
    problem = random_problem(5, limit_steps=1, spread=0.3)
    assert get_optimizer("pso", seed=1, n_solutions=200).solve(problem).given_up == ()


def test_no_dimension_in_reach_gives_the_least_correction() -> None:
    """One dimension out of reach of a ±1-step register (hypothesis found it): x = 0, given up, no crash."""
    problem = random_problem(1845, n=1, m=1, limit_steps=1)
    result = get_optimizer("exact", objective="paper").solve(problem)
    assert brute_triage(problem)[0] == 0
    assert result.status == "optimal"
    assert np.all(result.x == 0)
    assert result.given_up == problem.dimension_ids


@pytest.mark.parametrize("seed", range(8))
def test_bound_is_the_kept_dimensions_lp_and_seconds_the_whole_call(seed: int, path: str) -> None:
    """The bound describes the final answer: the LP over the dimensions it keeps (held ones held)."""
    from scipy.optimize import linprog

    problem = random_problem(seed, n=3, m=7, limit_steps=2, spread=0.3)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem)
    if not result.given_up:
        pytest.skip("every dimension can be kept: no triage")
    keep = ~np.isin(problem.dimension_ids, result.given_up)
    held = np.isfinite(problem.held_floor)
    ct = problem.composite.T  # (m, n)
    dev, up, lo, fl = problem.deviation, problem.upper, problem.lower, problem.held_floor
    a = np.r_[
        np.c_[ct[keep], np.ones(keep.sum())],
        np.c_[-ct[keep], np.ones(keep.sum())],
        np.c_[ct[held], np.zeros(held.sum())],
        np.c_[-ct[held], np.zeros(held.sum())],
    ]
    b = np.r_[(up - dev)[keep], (dev - lo)[keep], (up - dev - fl)[held], (dev - lo - fl)[held]]
    lp = linprog(
        np.r_[np.zeros(problem.n_registers), -1.0],
        A_ub=a,
        b_ub=b,
        bounds=[*zip(problem.lb, problem.ub, strict=True), (None, None)],
        method="highs",
    )
    assert result.bound == pytest.approx(-lp.fun, abs=1e-9)
    assert result.bound is not None and result.bound >= result.margin_after - 1e-12
    assert result.triage is not None
    assert result.triage.lp_bound_all < result.bound  # the whole problem's, given-up dimensions included
    assert result.seconds >= sum(result.stages.values()) - 1e-9
    assert result.status == "optimal" and result.triage.leximin_complete
    assert ("listing" in result.path) == (path == "listed")


def gross_problem(seed: int, n: int = 4, m: int = 8) -> CorrectionProblem:
    """Every dimension measured in tolerance but one or two grossly out (some within the box's reach,
    some not): the shop's commonest triage."""
    import dataclasses

    rng = np.random.default_rng(5000 + seed)
    base = random_problem(5000 + seed, n=n, m=m, limit_steps=3, spread=0.0)
    dev = rng.uniform(0.3, 0.9, m) * np.where(rng.random(m) < 0.5, base.lower, base.upper)  # all inside
    gross = rng.choice(m, size=1 + seed % 2, replace=False)
    side = rng.choice([-1.0, 1.0], gross.size)
    dev[gross] = np.where(side > 0, base.upper[gross], base.lower[gross]) + side * rng.uniform(0.02, 0.4, gross.size)
    return dataclasses.replace(base, deviation=np.round(dev, 4))


@pytest.mark.parametrize("seed", range(20))
def test_gross_dimensions_triage_equals_brute_force(seed: int, path: str) -> None:
    problem = gross_problem(seed)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS[path]).solve(problem)
    if brute_triage(problem)[0] == len(problem.dimension_ids):
        assert result.given_up == ()
        return
    check_triage(problem, result)
    assert ("kept set forced" in result.path) == (path == "forced")  # everything measured in is kept


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_gross_dimensions_triage_equals_an_independent_milp(seed: int) -> None:
    problem = gross_problem(seed, n=3, m=6)
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS["forced"]).solve(problem)
    if not result.given_up:
        pytest.skip("every dimension can be kept: no triage")
    assert "kept set forced" in result.path
    count, sorted_kept, norm = milp_triage(problem)
    margins = problem.margins(result.x)
    kept = np.array([d not in result.given_up for d in problem.dimension_ids])
    assert kept.sum() == count
    assert np.sort(margins[kept]) == pytest.approx(sorted_kept, abs=1e-7)
    assert np.sqrt(np.sum(problem.cost * result.x**2)) == pytest.approx(norm, abs=1e-7)


def test_a_dimension_within_reach_only_by_harm_is_proved_lost() -> None:
    """The LP certificate: D0 can be brought in only by moving D1 (measured in) out."""
    from setupfix.optimize.exact.lp_bound import margin_rows
    from setupfix.optimize.exact.triage.forced import lost_bound
    from setupfix.optimize.exact.triage.model import TriageRows

    problem = CorrectionProblem(
        np.array([[1.0, 1.0]]),
        np.array([0.08, -0.03]),
        np.full(2, -0.05),
        np.full(2, 0.05),
        np.array([-0.1]),
        np.array([0.1]),
        0.01,
        ("R0",),
        ("D0", "D1"),
    )
    g_rows, g = margin_rows(problem)
    row_dim = np.r_[0, 1, 0, 1]
    t = TriageRows(
        g_rows,
        g,
        row_dim,
        problem.held_floor / 0.01,
        problem.kmin.astype(float),
        problem.kmax.astype(float),
        problem.cost,
    )
    assert not t.lost[0]  # the box reaches it (k ≤ −3 steps) …
    assert lost_bound(t, 0, 1.0) == pytest.approx(-1.0, abs=1e-5)  # … D1 stays in only for k ≥ −2: D0 at −1 step
    result = get_optimizer("exact", time_limit=SOLVE_LIMIT, settings=TRIAGE_PATHS["forced"]).solve(problem)
    assert result.given_up == ("D0",) and result.status == "optimal"
    assert "kept set forced" in result.path
    assert result.x == pytest.approx([0.03], abs=1e-12)  # D1 centred


def test_guide_pins_gross_dimension_is_fast_and_complete(guide_pins_model: ProcessModel) -> None:
    """The commonest case at paper size: P1 D1 at −0.25 mm.  The kept set is forced: the whole leximin
    vector and the least norm are proved well within the limit, and the correction is the one the MILP
    path finds alone with a 120 s limit (bench/triage_paper_size.py --check)."""
    (part,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    dev = part.deviation.copy()
    dev[0] = -0.25
    problem = CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, dev, part.sources))
    result = get_optimizer("exact").solve(problem)
    assert result.status == "optimal" and result.stopped is None and result.triage is not None
    assert result.triage.leximin_complete and result.triage.kept == 27
    assert "kept set forced" in result.path
    assert result.x == pytest.approx([0.007, -0.002, -0.01, -0.004, 0.013, 0.027, 0.0, 0.012, 0.016, 0.03], abs=1e-12)
    assert result.work < 1000  # the MILP path: ~29,000 work units (bench/triage_paper_size.py times it)


@pytest.mark.slow
def test_an_incomplete_triage_leximin_is_a_stopped_solve(guide_pins_model: ProcessModel) -> None:
    """Levels left unproved (their share of the limit spent) never read as optimal."""
    from setupfix.correction.recommend import stopped_rule

    (part,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    dev = part.deviation.copy()
    dev[0] = -0.25
    problem = CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, dev, part.sources))
    only_level_1 = ExactSettings(forced_triage=False, triage_leximin_share=0.0)
    result = get_optimizer("exact", settings=only_level_1).solve(problem)
    assert result.triage is not None and not result.triage.leximin_complete
    assert result.status == "time_limit"
    assert result.stopped is not None and result.stopped.detail is not None
    assert result.stopped.stage == "triage" and result.stopped.reason == "work limit"
    assert "leximin" in result.stopped.detail
    assert result.given_up == ("P1D1",) and np.all(np.delete(problem.margins(result.x), 0) >= 0)
    assert "triage stage stopped" in stopped_rule(result, recommended=True).message
