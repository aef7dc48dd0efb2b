"""Properties every comparison optimiser (PSO, GA, COA, CS) must have.

Grid, bounds and fixed registers of every evaluated solution; determinism per
seed; the solution count; the gap to the brute-force optimum on a small grid and
to the exact optimum on the paper's guide-pins sets.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar, overload

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.optimize import CorrectionProblem, get_optimizer

Array = npt.NDArray[np.float64]
P = TypeVar("P", bound=CorrectionProblem)

GUIDE_PINS = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"

#: name → small-budget hyper-parameters for the small problem
SMALL = {
    "pso": {"n_particles": 20, "n_solutions": 2000},
    "ga": {"population": 20, "n_solutions": 2000},
    "coa": {"max_cuckoos": 20, "n_iterations": 30, "n_solutions": 2000},
    "cs": {"n_nests": 15, "n_solutions": 2000},
}
METHODS = sorted(SMALL)


@dataclass(frozen=True)
class RecordingProblem(CorrectionProblem):
    """A problem that remembers every row it evaluates."""

    log: list[np.ndarray] = field(default_factory=list, compare=False)

    def evaluate(self, x: Array) -> tuple[Array, Array, Array]:
        self.log.append(np.atleast_2d(np.asarray(x, dtype=float)).copy())
        return super().evaluate(x)


@overload
def small_problem(seed: int = 0) -> CorrectionProblem: ...


@overload
def small_problem(seed: int, cls: type[P]) -> P: ...


def small_problem(seed: int = 0, cls: type[CorrectionProblem] = CorrectionProblem) -> CorrectionProblem:
    """5 registers (the last fixed), 8 dimensions, grid step 0.01 within ±0.1: 21⁴ = 194,481 points."""
    rng = np.random.default_rng(seed)
    comp = rng.integers(-1, 2, size=(5, 8)).astype(float)
    comp[:, :4] = np.vstack([np.eye(4), np.ones(4)])  # every register acts somewhere
    return cls(
        composite=comp,
        deviation=rng.uniform(-0.12, 0.12, 8),
        lower=np.full(8, -0.1),
        upper=np.full(8, 0.1),
        lb=np.array([-0.1, -0.1, -0.1, -0.1, 0.0]),
        ub=np.array([0.1, 0.1, 0.1, 0.1, 0.0]),
        resolution=0.01,
        register_ids=("W1", "W2", "W3", "T1", "T2"),
        dimension_ids=tuple(f"D{i}" for i in range(8)),
    )


def brute_force(problem: CorrectionProblem) -> float:
    """Largest f over every grid point within the bounds."""
    axes = [np.arange(k0, k1 + 1) * problem.resolution for k0, k1 in zip(problem.kmin, problem.kmax, strict=True)]
    grid = np.array(list(itertools.product(*axes)))
    return float(np.max(problem.evaluate(grid)[2]))


def guide_pins_problem(cycle: int) -> CorrectionProblem:
    from setupfix.inputs.cycles import load_parts
    from setupfix.model import load_model

    model = load_model(GUIDE_PINS / "model.toml")
    part = load_parts(model, GUIDE_PINS / f"cycle_{cycle:02d}.csv")[0]
    return CorrectionProblem.from_part(model, part)


@pytest.mark.slow
@pytest.mark.parametrize("name", METHODS)
def test_small_problem_reaches_the_brute_force_optimum(name: str) -> None:
    hits = 0
    for case in range(3):
        problem = small_problem(10 + case)
        best = brute_force(problem)
        for seed in range(3):
            result = get_optimizer(name, seed=seed, **SMALL[name]).solve(problem)
            assert result.fitness <= best + 1e-12
            hits += result.fitness >= best - 1e-9
    # Random search with the same budget finds it in 0 of these 9 runs (checked when the test was written).
    assert hits >= 4, f"{name} found the brute-force optimum in only {hits} of 9 runs"


#: Issue 4 targets: median gap of f1 to the exact grid optimum [mm] at the paper's budgets.
TARGET = {"pso": 0.010, "ga": 0.010, "coa": 0.025, "cs": 0.025}


@pytest.mark.slow
@pytest.mark.parametrize("name", METHODS)
def test_paper_size_gap_to_exact_optimum(name: str) -> None:
    exact_cls = pytest.importorskip("setupfix.optimize.exact.solve").ExactOptimizer
    for cycle in (1, 2):
        problem = guide_pins_problem(cycle)
        exact = exact_cls().solve(problem)
        assert exact.status == "optimal"
        gaps = [exact.margin_after - get_optimizer(name, seed=s).solve(problem).margin_after for s in range(5)]
        assert min(gaps) >= -1e-9, "a metaheuristic beat the proved grid optimum"
        assert np.median(gaps) <= TARGET[name]
