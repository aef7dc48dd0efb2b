"""The exact solver's structure: validated settings, stages in layers, typed stage results."""

from __future__ import annotations

import ast
import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.core.errors import ParameterError
from setupfix.optimize import get_optimizer
from setupfix.optimize.exact.grid_optimum import LEVEL_STRATEGIES, GridLevel, GridOptimum, StrategyAnswer
from setupfix.optimize.exact.lp_bound import lp_bound, margin_rows
from setupfix.optimize.exact.session import GridRows, Session
from setupfix.optimize.exact.settings import ExactSettings

from .test_exact import brute_force, random_problem

OPTIMIZE = Path(__file__).resolve().parents[2] / "setupfix" / "optimize"

#: The optimiser's parts in reading order, bottom to top: each imports only parts of a lower rank (its own
#: part included).  The exact solve's stages read upwards: the session, the LP bound, the grid optimum and
#: the least norm among its points, the leximin levels, the triage, and the solve that runs them in order.
RANKS: dict[str, float] = {
    "problem": 0,
    "exact.settings": 0,
    "exact.work": -1,
    "exact.highs": 0,
    "exact.grid": 0,
    "dimensions": 1,
    "base": 1,
    "exact.least_norm.listing": 1,
    "exact.least_norm.chords": 1,
    "exact.least_norm.shop": 1.5,
    "heuristics": 2,
    "exact.session": 2,
    "exact.farkas": 3,
    "exact.lp_bound": 3,
    "exact.grid_optimum": 4,
    "exact.least_norm.grid": 4,
    "exact.leximin": 5,
    "exact.triage": 6,
    "exact.solve": 7,
    "exact": 8,
}

Array = npt.NDArray[np.float64]
Strategy = Callable[[Session, GridLevel], StrategyAnswer]


def logged(events: list[str], strategy: Strategy) -> Strategy:
    """``strategy``, noting "listing" in ``events`` each time it runs."""

    def run(session: Session, level: GridLevel) -> StrategyAnswer:
        events.append("listing")
        return strategy(session, level)

    return run


def part_of(module: str) -> str:
    """The :data:`RANKS` entry of a module of ``setupfix.optimize`` (the longest prefix)."""
    rel = module.removeprefix("setupfix.optimize.")
    return max((k for k in RANKS if rel == k or rel.startswith(k + ".")), key=len)


MODULES = sorted(
    ".".join(p.relative_to(OPTIMIZE.parent.parent).with_suffix("").parts).removesuffix(".__init__")
    for p in OPTIMIZE.rglob("*.py")
    if p.parent != OPTIMIZE or p.name != "__init__.py"
)


@pytest.mark.parametrize("module", MODULES)
def test_solver_modules_import_only_lower_ranks(module: str) -> None:
    path = OPTIMIZE.parent.parent / (module.replace(".", "/") + ".py")
    if not path.exists():
        path = path.with_suffix("") / "__init__.py"
    own = part_of(module)
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("setupfix.optimize."):
            target = part_of(node.module)
            assert target == own or RANKS[target] < RANKS[own], f"{module} ({own}) imports {node.module} ({target})"


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("quantum", 0.0),
        ("level_steps", -1),
        ("box_share", 1.5),
        ("working_set_nnls", 1),
        ("search_limit", 2.5),
        ("max_pair_tests", -1),
        ("tight_slack", float("inf")),
        ("triage_leximin_share", 1.0),
        ("forced_triage", "yes"),
        ("climb_scales", ()),
        ("climb_scales", (4.0, 0.5)),
        ("link_count_blocks", None),
    ],
)
def test_settings_are_validated_naming_the_field(field: str, value: Any) -> None:
    with pytest.raises(ParameterError, match=f"ExactSettings: {field}"):
        ExactSettings(**{field: value})


def test_settings_are_frozen_and_reach_the_optimizer_through_the_registry() -> None:
    settings = ExactSettings(level_steps=0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.level_steps = 3  # type: ignore[misc]
    assert get_optimizer("exact", time_limit=1.0, settings=settings).get_params()["settings"] is settings
    with pytest.raises(ParameterError, match="settings"):
        get_optimizer("exact", settings={"level_steps": 0})


def test_a_coarser_quantum_rounds_the_deviations_it_says() -> None:
    problem = random_problem(3)
    _, g_fine = margin_rows(problem)
    _, g_coarse = margin_rows(problem, quantum=0.5)
    diff = np.abs(g_fine - g_coarse)
    assert np.max(diff) <= 0.25 + 1e-12 and np.max(diff) > 0.01  # rounded to half steps, and it shows


@pytest.mark.parametrize("seed", range(4))
def test_stage_results_are_frozen_and_bracket_the_brute_force_optimum(seed: int) -> None:
    problem = random_problem(100 + seed, n=4, m=8, limit_steps=6)
    g_rows, g = margin_rows(problem)
    free = problem.free
    rows = GridRows(g_rows, g, problem.kmin[free].astype(float), problem.kmax[free].astype(float), problem.cost[free])
    session = Session(rows, ExactSettings())
    bound = lp_bound(session)
    assert bound is not None
    from setupfix.optimize.exact.grid_optimum import grid_optimum

    opt = grid_optimum(session, bound)
    assert isinstance(opt, GridOptimum)
    with pytest.raises(dataclasses.FrozenInstanceError):
        opt.t = 0.0  # type: ignore[misc]
    best, _ = brute_force(problem)
    assert opt.t * problem.resolution == pytest.approx(best, abs=1e-12)  # t* in steps, proved
    assert opt.stopped is None and opt.upper >= opt.t - 1e-9
    assert bound.t >= opt.upper - 1e-9  # LP bound ≥ grid bound ≥ grid optimum
    assert [s.__name__ for s in LEVEL_STRATEGIES] == [
        "relax",
        "rounded_relaxation",
        "listing",
        "unit_boxes",
        "feasibility_milp",
    ]


@pytest.mark.parametrize("seed", range(12))
def test_a_callers_search_in_the_grid_optimum_changes_no_optimum(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The grid optimum with a caller's search (the leximin climb; here also one that answers badly) proves
    the brute-force optimum; where the search's point reaches the level, the listing is never run."""
    import setupfix.optimize.exact.grid_optimum as go
    from setupfix.optimize.dimensions import dimension_of_rows, model_dimensions
    from setupfix.optimize.exact.leximin.levels import root_climb

    problem = random_problem(200 + seed, n=4, m=8, limit_steps=6)
    g_rows, g = margin_rows(problem)
    free = problem.free
    rows = GridRows(g_rows, g, problem.kmin[free].astype(float), problem.kmax[free].astype(float), problem.cost[free])
    best, _ = brute_force(problem)
    row_dim, n_dims = dimension_of_rows(problem), len(model_dimensions(problem)[0])
    events: list[str] = []
    listing = go.listing
    monkeypatch.setattr(
        go,
        "LEVEL_STRATEGIES",
        tuple(logged(events, f) if f is listing else f for f in go.LEVEL_STRATEGIES),
    )
    session = Session(rows, ExactSettings())
    for search in (lambda k: root_climb(session, row_dim, n_dims, k), lambda k: np.array(rows.kmax)):
        bound = lp_bound(session)
        assert bound is not None
        plain = go.grid_optimum(Session(rows, ExactSettings()), bound)
        if plain.upper < 0:  # no correction brings every dimension in: the triage's case, not this stage's
            continue
        opt_t = plain.t
        events.clear()

        def spy(k: Array, search: Callable[[Array], Array | None] = search, opt_t: float = opt_t) -> Array | None:
            out = search(k)
            events.append(
                "reached" if out is not None and float(np.min(g - g_rows @ out)) >= opt_t - 1e-9 else "search"
            )
            return out

        opt = go.grid_optimum(session, bound, spy)
        assert (
            opt.stopped is None
            and opt.t == pytest.approx(opt_t)
            and opt.t * problem.resolution == pytest.approx(best, abs=1e-12)
        )
        assert float(np.min(g - g_rows @ opt.k)) == pytest.approx(opt.t)
        if "reached" in events:  # the search's point proves the optimum: no listing after it
            assert "listing" not in events[events.index("reached") :]


def test_results_of_g_alone_are_computed_once_per_model_and_read_only() -> None:
    """Two reports of one model (same G, box, costs; other g) share the memo; another box does not; a full
    memo is emptied, never grown without bound."""
    rng = np.random.default_rng(5)
    g_rows = rng.integers(-2, 3, size=(6, 3)).astype(float)
    box = (np.full(3, -4.0), np.full(3, 4.0), np.ones(3))
    made: list[int] = []

    def make() -> Array:
        made.append(1)
        out: Array = g_rows.sum(axis=0)
        return out

    first = GridRows(g_rows, rng.normal(size=6), *box).memo(("test",), make)
    again = GridRows(g_rows.copy(), rng.normal(size=6), *box).memo(("test",), make)
    assert made == [1] and again is first and not first.flags.writeable
    GridRows(g_rows, rng.normal(size=6), np.full(3, -5.0), box[1], box[2]).memo(("test",), make)
    assert made == [1, 1]
    rows = GridRows(g_rows, rng.normal(size=6), *box)
    for i in range(5):
        rows.memo(("fill", i), make, most=3)
    assert len(rows.derived.memo) <= 3
