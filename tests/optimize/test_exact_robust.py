"""Exact optimiser: every proof path against brute force, solver errors, input quantum, time limit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.inputs.cycles import load_parts
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.optimize.exact.highs import Solve
from setupfix.optimize.exact.session import Session
from setupfix.optimize.exact.settings import ExactSettings
from setupfix.optimize.exact.work import now

from .test_exact import brute_force, random_problem

DATA = Path(__file__).resolve().parents[1] / "data" / "exact_solve_error"
GUIDE_PINS = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"

#: Settings that switch the shortcuts off, so that each fallback is checked too.
PATHS = {
    "shortcuts": ExactSettings(),
    "grid MILP": ExactSettings(level_steps=0, search_limit=0),
    "box MILPs": ExactSettings(enumeration_limit=0, search_limit=0),
    "lazy chord MILP": ExactSettings(enumeration_limit=0, search_limit=0, box_proof_max_registers=0),
    "working-set NNLS": ExactSettings(nnls_max_rows=0),
    "HiGHS QP": ExactSettings(nnls_max_rows=0, working_set_nnls=False),
}

Array = npt.NDArray[np.float64]


@pytest.mark.slow
@pytest.mark.parametrize("path", list(PATHS))
@pytest.mark.parametrize("seed", range(6))
def test_every_proof_path_equals_brute_force(path: str, seed: int) -> None:
    problem = random_problem(100 + seed, n=4, m=8, limit_steps=6)
    result = get_optimizer("exact", objective="paper", settings=PATHS[path]).solve(problem)
    best, norm = brute_force(problem)
    assert result.status == "optimal"
    assert result.margin_after == pytest.approx(best, abs=1e-12)
    assert result.norm == pytest.approx(norm, abs=1e-12)


def test_solve_error_repro_is_optimal() -> None:
    """The report on which HiGHS once answered "Solve error": optimum and least norm, proved."""
    # The solver itself: the repro's random deviations lie beyond the default reject band of
    # the safety rules (setupfix.correction.safety), so `correct` would refuse the report before solving.
    from setupfix.model import load_model

    model = load_model(DATA / "model.toml")
    (part,) = load_parts(model, DATA / "report.csv")
    result = get_optimizer("exact", objective="paper").solve(CorrectionProblem.from_part(model, part))
    assert result.status == "optimal"
    assert result.margin_after == pytest.approx(0.0004, abs=1e-9)
    assert result.norm == pytest.approx(0.0677, abs=1e-4)  # 0.195 mm before the fix
    assert not [n for n in result.notes if "HiGHS answered" in n.message]


def test_solver_error_is_retried_without_the_lower_bracket_and_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    real = Session.max_margin_milp
    brackets: list[float] = []

    def failing_once(  # HiGHS's "Solve error", once
        self: Session, t_lo: float, t_hi: float, start: Array | None, time_limit: float
    ) -> Solve:
        brackets.append(t_lo)
        if len(brackets) == 1:
            return Solve("error", "Solve error", None, float("nan"), float("nan"), None, None, 0.0)
        return real(self, t_lo, t_hi, start, time_limit)

    monkeypatch.setattr(Session, "max_margin_milp", failing_once)
    problem = random_problem(1, n=4, m=8, limit_steps=6)  # in reach, and the rounded LP point is not optimal
    result = get_optimizer("exact", objective="paper", settings=ExactSettings(level_steps=0, search_limit=0)).solve(
        problem
    )
    assert len(brackets) == 2 and brackets[1] < brackets[0]  # the retry drops the lower bracket
    assert result.status == "optimal"
    assert result.margin_after == pytest.approx(brute_force(problem)[0], abs=1e-12)
    assert any("Solve error" in n.message and "retried" in n.message for n in result.notes)


def test_csv_and_in_memory_inputs_give_identical_corrections(guide_pins_model: ProcessModel) -> None:
    """The last bits of the deviations (actual − nominal in floating point) change nothing."""
    import pandas as pd

    (from_csv,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    table = pd.read_csv(GUIDE_PINS / "cycle_01.csv")
    rows = [int(src.rsplit(":", 1)[1]) - 2 for src in from_csv.sources]  # file line → table row
    # The report's deviation column and actual − nominal differ in their last bits (24.9691 − 25 ≠ −0.0309);
    # take whichever the reader did not use.
    printed = table["deviation"].to_numpy()[rows]
    computed = (table["actual"] - table["nominal"]).to_numpy()[rows]
    assert not np.array_equal(printed, computed)
    if np.array_equal(computed, from_csv.deviation):
        computed = printed
    np.testing.assert_allclose(computed, from_csv.deviation, atol=1e-12)
    in_memory = PartMeasurement(from_csv.part, "memory", None, computed, from_csv.sources)
    a = get_optimizer("exact", objective="paper").solve(CorrectionProblem.from_part(guide_pins_model, from_csv))
    b = get_optimizer("exact", objective="paper").solve(CorrectionProblem.from_part(guide_pins_model, in_memory))
    np.testing.assert_array_equal(a.x, b.x)


def shop_problem(n: int, m: int, seed: int) -> CorrectionProblem:
    """A random multi-part fixture (as bench/exact_scaling.py): WKS + tool per feature, 30 % differences."""
    rng = np.random.default_rng(seed)
    n_wks = 2 * n // 3
    feat = np.zeros((n, m))
    sign = rng.choice([-1.0, 1.0], m)
    feat[rng.integers(0, n_wks, m), np.arange(m)] = sign
    feat[n_wks + rng.integers(0, n - n_wks, m), np.arange(m)] = sign
    comp = feat[:, rng.permutation(m)].copy()
    pairs = rng.random(m) < 0.3
    comp[:, pairs] -= feat[:, rng.integers(0, m, m)][:, pairs]
    lower = -np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    upper = np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    dev = np.round(0.03 * (1 - 2 * rng.random(n)) @ comp + 0.01 * (1 - 2 * rng.random(m)), 4)
    return CorrectionProblem(
        composite=comp,
        deviation=dev,
        lower=lower,
        upper=upper,
        lb=np.full(n, -0.1),
        ub=np.full(n, 0.1),
        resolution=0.001,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def test_the_work_limit_stops_a_stage_the_same_way_every_time_and_says_which() -> None:
    """A shop-sized problem with a small work budget: the stage that stops, the point and the words are the
    same on every run (work, not wall time; how long it takes is ``bench/work_limits.py``'s)."""
    problem = shop_problem(60, 400, 2)
    optimizer = get_optimizer("exact", objective="paper", settings=ExactSettings(work_limit=5000.0))
    result, again = optimizer.solve(problem), optimizer.solve(problem)
    assert result.margin_after >= problem.margin_before  # a stopped search still improves on nothing
    assert result.status == "time_limit" and result.stopped is not None
    assert result.stopped.reason == "work limit" and result.stopped.stage in ("grid optimum", "least norm")
    assert result.bound is not None and result.margin_after <= result.bound + 1e-12
    assert any("work limit" in n.message for n in result.notes)
    assert not any("time limit" in n.message for n in result.notes)
    np.testing.assert_array_equal(result.x, again.x)
    assert (result.stopped, result.message, result.path) == (again.stopped, again.message, again.path)
    assert result.work == again.work


def test_the_wall_clock_guard_gives_no_correction_never_another_one() -> None:
    """The time limit only guards against a hang: when it fires, the result is x = 0 with the stopped status,
    never the best point found so far."""
    problem = shop_problem(60, 400, 2)
    result = get_optimizer("exact", objective="leximin", time_limit=1e-9).solve(problem)
    assert result.status == "time_limit" and result.stopped is not None and result.stopped.reason == "time limit"
    assert not np.any(result.x) and result.margin_after == pytest.approx(problem.margin_before)
    assert any("time limit" in n.message and "--time-limit" in n.message for n in result.notes)


def test_cli_time_limit_option(capsys: pytest.CaptureFixture[str]) -> None:
    from setupfix.cli import main

    args = ["correct", "--model", str(GUIDE_PINS / "model.toml"), str(GUIDE_PINS / "cycle_01.csv")]
    assert main([*args, "--time-limit", "5", "--json"]) == 0
    assert main([*args, "--time-limit", "0"]) == 1
    assert "time_limit must be a number in (0, inf)" in capsys.readouterr().err
    assert main([*args, "--optimizer", "pso", "--time-limit", "1"]) == 1
    assert "--time-limit applies to the exact optimizer" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize(("objective", "count", "threads"), [("paper", 8, 2), ("leximin", 24, 4)])
def test_threads_keep_their_own_solver_models(
    guide_pins_model: ProcessModel, objective: str, count: int, threads: int
) -> None:
    """Solves in worker threads (batch, TUI) give the same corrections as one after another — also while the
    threads fill the per-model memo of results of G alone at once (it starts empty)."""
    from concurrent.futures import ThreadPoolExecutor

    import setupfix.optimize.exact.session as session_mod
    from setupfix.correction.synthetic import simulate_deviations

    devs, _ = simulate_deviations(guide_pins_model, count, seed=3)
    problems = [
        CorrectionProblem.from_part(guide_pins_model, PartMeasurement("c", "r", None, d, ("",) * d.size)) for d in devs
    ]
    alone = [get_optimizer("exact", objective=objective).solve(p).x for p in problems]
    session_mod.DERIVED.clear()
    with ThreadPoolExecutor(max_workers=threads) as pool:
        threaded = list(pool.map(lambda p: get_optimizer("exact", objective=objective).solve(p).x, problems))
    for a, b in zip(alone, threaded, strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_very_fine_grid_neither_hangs_nor_loses_the_bound(guide_pins_model: ProcessModel) -> None:
    """Resolution 1e-11 mm: 10^10 steps per register; bounded in work, never worse than the 0.001 grid (its
    time: ``bench/work_limits.py``)."""
    import dataclasses

    (part,) = load_parts(guide_pins_model, GUIDE_PINS / "cycle_01.csv")
    coarse = CorrectionProblem.from_part(guide_pins_model, part)
    fine = dataclasses.replace(coarse, resolution=1e-11)
    result = get_optimizer("exact", objective="paper").solve(fine)
    assert get_optimizer("exact", objective="paper").solve(coarse).margin_after - 1e-12 <= result.margin_after
    assert result.bound is not None and result.margin_after <= result.bound + 1e-12


def test_the_answer_does_not_depend_on_the_reports_solved_before(guide_pins_model: ProcessModel) -> None:
    """A solve starts from scratch (its own session), or a report whose least norm is attained at two
    grid points gets one or the other depending on history (batch workers would then disagree).  The
    pair of reports below showed it when solver models were kept across reports."""
    data = Path(__file__).resolve().parent / "data"
    (before,) = load_parts(guide_pins_model, data / "history_before.csv")
    (tie,) = load_parts(guide_pins_model, data / "history_tie.csv")
    opt = get_optimizer("exact", objective="paper")
    fresh = opt.solve(CorrectionProblem.from_part(guide_pins_model, tie))
    opt.solve(CorrectionProblem.from_part(guide_pins_model, before))
    after = opt.solve(CorrectionProblem.from_part(guide_pins_model, tie))
    assert fresh.status == after.status == "optimal"
    np.testing.assert_array_equal(after.x, fresh.x)


def test_the_leximin_stage_ends_by_its_share_of_the_work_and_leaves_the_least_norm_its_own() -> None:
    """At 100 × 800 the single-dimension tests of a discrete conflict are hundreds of LPs: they stop when the
    stage's share of the work is spent (they used to run on, past the whole limit, and leave the least norm
    nothing: a correction of 0.67 mm where the least norm at the levels reached is 0.14 mm)."""
    problem = shop_problem(100, 800, 1)
    settings = ExactSettings(work_limit=100_000.0)
    result = get_optimizer("exact", objective="leximin", settings=settings).solve(problem)
    assert result.status == "time_limit" and result.stopped is not None and result.stopped.stage == "leximin"
    assert result.stopped.reason == "work limit" and "least norm" in result.stages
    assert result.work <= settings.work_limit * 1.2  # one point test past the share at most
    paper = get_optimizer("exact", objective="paper").solve(problem)
    assert result.margin_after == pytest.approx(paper.margin_after, abs=1e-12)  # δ was proved before the levels


def test_a_point_test_starts_no_solve_once_its_stage_is_over(monkeypatch: pytest.MonkeyPatch) -> None:
    from setupfix.optimize.exact.leximin.pins import point_above
    from setupfix.optimize.exact.lp_bound import margin_rows
    from setupfix.optimize.exact.session import GridRows

    problem = shop_problem(30, 100, 0)
    g_rows, g = margin_rows(problem)
    rows = GridRows(g_rows, g, problem.kmin.astype(float), problem.kmax.astype(float), problem.cost)
    session = Session(rows, ExactSettings())
    monkeypatch.setattr(Session, "rounded_rows_feasible", lambda *a, **k: pytest.fail("a solve was started"))
    assert point_above(session, np.full(g.size, -np.inf), now() - 1e-6) is None
