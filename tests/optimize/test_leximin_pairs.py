"""Discrete conflicts that two dimensions must share (issue 22): branches on pairs, against brute force, the
count MILPs and the grid — on guide-pins reports where they occur (``data/pair_conflicts``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

import setupfix.optimize.exact.leximin.levels as lexmod
from setupfix.model import load_model
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.optimize.exact import ExactSettings
from setupfix.optimize.exact.leximin.pins import excluded_alone
from setupfix.optimize.exact.session import GridRows

from .test_leximin import brute_leximin, solved_steps, steps_margins

ROOT = Path(__file__).resolve().parents[2]
Array = npt.NDArray[np.float64]
REPORTS = sorted((Path(__file__).parent / "data" / "pair_conflicts").glob("*.csv"))


def report_problem(path: Path) -> CorrectionProblem:
    from setupfix.inputs.cycles import load_parts

    model = load_model(ROOT / "sample_reports" / "guide_pins" / "model.toml")
    return CorrectionProblem.from_part(model, load_parts(model, path)[0])


def window(problem: CorrectionProblem, objective: str) -> CorrectionProblem:
    """Every register limited to the objective's answer ± 1 step: 3^10 grid points (brute force)."""
    x = get_optimizer("exact", objective=objective, time_limit=30.0).solve(problem).x
    h = problem.resolution
    return dataclasses.replace(problem, lb=np.where(problem.free, x - h, 0.0), ub=np.where(problem.free, x + h, 0.0))


def test_the_bundled_pair_conflicts_are_three() -> None:
    assert len(REPORTS) == 3


@pytest.mark.slow
@pytest.mark.parametrize("report", REPORTS, ids=lambda p: p.stem)
def test_pair_branches_decide_the_whole_report_as_the_counts_would(report: Path) -> None:
    """The full report (±100 steps): the conflict goes to pair branches, proved within the default work limit;
    with the pairs switched off the count MILPs (the generic way, tested against brute force) give the
    same leximin margins and the same correction (on the one report where they take seconds, not tens)."""
    problem = report_problem(report)
    result = get_optimizer("exact", objective="leximin").solve(problem)
    assert result.status == "optimal", result.message
    assert "branch: dimensions" in result.path and "by counts" not in result.path
    if report.stem != "varied_r00264":  # the counts take 10-20 s on the other two (bench/leximin_speed.py)
        return
    no_pairs = ExactSettings(max_pair_tests=0)
    counts = get_optimizer("exact", objective="leximin", time_limit=120.0, settings=no_pairs).solve(problem)
    assert counts.status == "optimal" and "by counts" in counts.path
    np.testing.assert_array_equal(result.x, counts.x)
    k = np.rint(result.x[problem.free] / problem.resolution)[None, :]
    k_c = np.rint(counts.x[problem.free] / problem.resolution)[None, :]
    np.testing.assert_allclose(np.sort(steps_margins(problem, k)), np.sort(steps_margins(problem, k_c)))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("report", "centre"),
    [(r, c) for r in REPORTS for c in ("paper", "leximin")],
    ids=lambda v: v.stem if isinstance(v, Path) else v,
)
def test_pair_branches_equal_brute_force_on_windows(report: Path, centre: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows of ±1 step around the paper's or the leximin answer; every pair the Farkas certificate
    excludes is checked on the grid: no point has every other active dimension above t + ε."""
    problem = window(report_problem(report), centre)
    best, norm, _ = brute_leximin(problem)
    claims: list[int] = []
    original = excluded_alone

    def checked(
        rows: GridRows,
        floors: Array,
        row_dim: npt.NDArray[np.intp],
        n_dims: int,
        t: float,
        eps: float,
        together: int = 1,
        near: Array | None = None,
    ) -> npt.NDArray[np.bool_]:
        out = original(rows, floors, row_dim, n_dims, t, eps, together, near)
        if together == 2:
            free = problem.free
            axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin[free], problem.kmax[free], strict=True)]
            pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes)).astype(float)
            m_rows = rows.g[None, :] - pts @ rows.g_rows.T
            m = np.full((len(pts), n_dims), np.inf)
            for j, q in enumerate(row_dim):
                m[:, q] = np.minimum(m[:, q], m_rows[:, j])
            v = np.full(n_dims, np.nan)
            v[row_dim] = floors
            active, fixed = np.isnan(v), np.isfinite(v)
            base = np.all(m[:, fixed] >= v[fixed] - 1e-9, axis=1)
            for a, b in zip(*np.nonzero(np.triu(out, 1)), strict=True):
                others = active.copy()
                others[[a, b]] = False
                alone = (
                    base
                    & (m[:, a] >= t - 1e-9)
                    & (m[:, b] >= t - 1e-9)
                    & np.all(m[:, others] >= t + eps - 1e-9, axis=1)
                )
                assert not alone.any(), f"dimensions {a}, {b} are the only ones at {t} at a grid point"
            claims.append(int(np.triu(out, 1).sum()))
        return out

    monkeypatch.setattr(lexmod, "excluded_alone", checked)
    result, k, sorted_m = solved_steps(problem)
    assert result.status == "optimal", result.message
    np.testing.assert_allclose(sorted_m, best, atol=1e-6)
    assert float(problem.cost[problem.free] @ k**2) == pytest.approx(norm, abs=1e-9)
    if "branch: dimensions" in result.path:
        assert claims  # the pairs were filtered by the certificate before their tests
