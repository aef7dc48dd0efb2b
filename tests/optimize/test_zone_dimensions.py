"""A position zone is ONE dimension for leximin and the triage (issue 23): brute force on small zone problems.

Each generated problem has a model with WKS X/Y/Z and a tool length on a ±3-step grid (2,401 grid
points), lengths along an axis and two circular position zones.  The brute force looks at every grid
point of the problem's own rows (the polygon the optimiser is given) with each zone's margin the
least of its facets' and each zone counted once: most dimensions in tolerance without harm (a zone
measured inside its circle keeps every facet at least min(0, its margin before)), then the leximin
of the kept margins level by level (a margin within half the input quantum above a level counts at it), then
the least norm, then the smallest k — on the rows the optimiser solves (deviations rounded to its input
quantum, 1/1000 step, which decides near-ties below it).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pandas as pd
import pytest

from setupfix.model import match_parts, model_from_dict
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer, harmed_columns
from setupfix.optimize.dimensions import dimension_floor, dimension_of_rows, model_dimensions
from setupfix.optimize.exact.lp_bound import margin_rows

from .leximin_reference import lexicographic_maxmin, prefix_sums
from .test_exact_triage import TRIAGE_PATHS

if TYPE_CHECKING:
    from multi_axis_fixtures import Fixture

RES = 0.001


@dataclass(frozen=True)
class Brute:
    """The brute-force lexicographic optimum (:func:`brute`): kept count, sorted kept margins [steps], least
    norm, the point k [steps], the dimensions given up and every dimension's ID."""

    count: int
    sorted: npt.NDArray[np.float64]
    norm: float
    k: tuple[float, ...]
    gone: tuple[str, ...]
    ids: tuple[str, ...]


TIE = 5e-4  # steps: half the input quantum; a margin less than this above a level counts at the level


def zone_problem(seed: int, spread: float = 0.006) -> CorrectionProblem:
    rng = np.random.default_rng(seed)
    features = {}
    for i in range(4):
        w = {a: float(rng.choice([-1.0, 1.0])) for a in "xyz"}
        features[f"F{i}"] = {"wks": {"W1": w}, "position": [float(v) for v in rng.uniform(-50, 50, 3)]}
        if i % 2 == 0:
            features[f"F{i}"]["tools"] = {"T1": 1.0}
    dims: dict[str, dict[str, Any]] = {}
    for i in range(3):
        tol = float(rng.choice([0.002, 0.003, 0.004]))
        dims[f"L{i}"] = {
            "name": f"L{i}",
            "axis": "XYZ"[int(rng.integers(3))],
            "features": {f"F{i}": 1},
            "nominal": 0,
            "lower": -tol,
            "upper": tol,
        }
    for i, plane in enumerate((["X", "Y"], ["X", "Z"])):
        dims[f"P{i}"] = {
            "name": f"P{i}",
            "kind": "position",
            "components": [f"P{i} {plane[0]}", f"P{i} {plane[1]}"],
            "axes": plane,
            "diameter": float(rng.choice([0.004, 0.006, 0.008])),
            "features": {f"F{i + 2}": 1},
        }
    model = model_from_dict(
        {
            "process": {"name": "zones", "axes": ["X", "Y", "Z"], "resolution": RES, "limit": 3 * RES},
            "wks": {"W1": {"register": "G54"}},
            "tools": {"T1": {"register": "H1"}},
            "features": features,
            "dimensions": dims,
        }
    )
    values: dict[str, float] = {}
    for d in dims.values():
        names = d.get("components", [d["name"]])
        values |= {n: float(v) for n, v in zip(names, rng.uniform(-spread, spread, len(names)), strict=True)}
    table = pd.DataFrame({"characteristic": list(values), "deviation": list(values.values()), "unit": "mm"})
    (part,) = match_parts(model, table)
    problem = CorrectionProblem.from_part(model, part)
    assert problem.circles is not None and len(problem.circles.ids) == 2
    return problem


def _grid(problem: CorrectionProblem) -> np.ndarray:
    axes = [np.arange(lo, hi + 1) for lo, hi in zip(problem.kmin, problem.kmax, strict=True)]
    return np.array(list(itertools.product(*axes)), dtype=float)


def _dimension_margins(problem: CorrectionProblem, x: np.ndarray) -> tuple[tuple[str, ...], np.ndarray]:
    """(ids, margins of shape (p, n_dims)) [unit]: a zone's the least of its facet columns', by the rows' names."""
    rows = problem.rows or problem.dimension_ids
    ids = tuple(dict.fromkeys(rows))
    m = problem.margins(x)
    return ids, np.stack([m[:, [r == d for r in rows]].min(axis=1) for d in ids], axis=1)


def _floors(problem: CorrectionProblem, ids: tuple[str, ...]) -> np.ndarray:
    """No harm by hand [unit]: a length inside its limits keeps margin ≥ 0; a zone inside its circle keeps its
    polygon margin ≥ min(0, polygon margin before); the others none (−inf)."""
    assert problem.circles is not None
    _, m0 = _dimension_margins(problem, np.zeros((1, problem.n_registers)))
    circle0 = dict(zip(problem.circles.ids, problem.circles.margins(np.zeros(problem.n_registers)), strict=True))
    out = np.full(len(ids), -np.inf)
    for q, d in enumerate(ids):
        inside = circle0[d] >= 0 if d in circle0 else m0[0, q] >= 0
        if inside:
            out[q] = min(0.0, m0[0, q])
    return out


def brute(problem: CorrectionProblem) -> Brute:
    """The lexicographic optimum over the whole grid (module docstring), in grid steps on the rows the
    optimiser solves: deviations rounded to the input quantum (``margin_rows``; the rounding is the
    optimiser's documented input, and decides near-ties below it), held rows ≥ min(floor, their margin
    at k = 0), levels as the optimiser defines them: each the best next-smallest kept margin (exact to 1e-6
    steps), then the fewest kept margins less than TIE above it.  Returns the count, the sorted kept margins
    [steps], the norm, the smallest optimal k and the dimensions given up."""
    g_rows, g = margin_rows(problem)
    row_dim = dimension_of_rows(problem)
    ids = tuple(dict.fromkeys(problem.rows or problem.dimension_ids))
    floor = _floors(problem, ids) / problem.resolution
    free = problem.free
    k = _grid(problem)[:, free]
    slack = g[None, :] - k @ g_rows.T
    m = np.stack([slack[:, row_dim == q].min(axis=1) for q in range(len(ids))], axis=1)
    held = np.isfinite(floor)
    hard = held[row_dim]
    ok = np.all(slack[:, hard] >= np.minimum(floor[row_dim][hard], g[hard])[None, :] - 1e-6, axis=1)
    kept = held[None, :] | (m >= -1e-6)
    count = np.where(ok, kept.sum(axis=1), -1)
    cands = np.flatnonzero(count == count.max())
    sorted_kept = np.sort(np.where(kept[cands], m[cands], np.inf), axis=1)
    alive, j = np.ones(cands.size, bool), 0
    while j < sorted_kept.shape[1] and np.isfinite(sorted_kept[alive, j]).any():
        value = sorted_kept[alive, j].max()  # the next level: the best j-th smallest kept margin …
        alive &= sorted_kept[:, j] >= value - 1e-6
        at = np.sum(sorted_kept < value + TIE - 1e-7, axis=1)  # … then the fewest margins within TIE above it
        alive &= at == at[alive].min()
        j = max(int(at[alive].min()), j + 1)
    cands = cands[alive]
    norms = np.sum(problem.cost[free] * k[cands] ** 2, axis=1)
    least = cands[norms <= norms.min() + 1e-9]
    best = min(map(tuple, k[least]))
    i = int(np.flatnonzero(np.all(k == best, axis=1))[0])
    return Brute(
        count=int(count.max()),
        sorted=np.sort(m[i][kept[i]]),
        norm=float(np.sqrt(norms.min())),
        k=best,
        gone=tuple(d for d, kp in zip(ids, kept[i], strict=True) if not kp),
        ids=ids,
    )


def _check(problem: CorrectionProblem, result: OptimizeResult, want: Brute) -> None:
    free = problem.free
    k = np.rint(result.x[free] / problem.resolution)
    assert result.status == "optimal"
    assert tuple(k) == want.k  # the whole lexicographic optimum: count, leximin, norm, smallest k
    ids, m = _dimension_margins(problem, result.x[None, :])
    floor = _floors(problem, ids)
    held = np.isfinite(floor)
    kept = held | (m[0] >= -1e-12)
    assert np.all(m[0, held] >= floor[held] - 1e-6 * problem.resolution)  # no harm, a zone as a whole
    assert int(kept.sum()) == want.count  # each zone counted once
    assert np.sort(m[0][kept]) / problem.resolution == pytest.approx(want.sorted, abs=1e-3)
    # given up: whole dimensions, every facet of a zone given up, named by the problem's columns
    gone = tuple(d for d, kp in zip(ids, kept, strict=True) if not kp)
    assert gone == want.gone
    rows = problem.rows or problem.dimension_ids
    assert set(result.given_up) == {c for c, r in zip(problem.dimension_ids, rows, strict=True) if r in gone}
    if gone:
        assert result.triage is not None and set(result.triage.given_up) == set(gone)
        assert result.triage.kept == len(ids) - len(gone)
        assert result.margin_after / problem.resolution == pytest.approx(want.sorted[0], abs=1e-3)  # δ kept


def half_step_problem(seed: int) -> CorrectionProblem:
    """Two registers (W1.X, W1.Y), deviations on half steps: exact ties and discrete conflicts (branches)."""
    rng = np.random.default_rng(seed)
    features = {f"F{i}": {"wks": {"W1": {a: float(rng.choice([-1.0, 1.0])) for a in "xy"}}} for i in range(5)}
    dims: dict[str, dict[str, Any]] = {}
    for i in range(3):
        tol = float(rng.choice([0.002, 0.003]))
        dims[f"L{i}"] = {
            "name": f"L{i}",
            "axis": "XY"[int(rng.integers(2))],
            "features": {f"F{i}": 1},
            "nominal": 0,
            "lower": -tol,
            "upper": tol,
        }
    for i in range(2):
        dims[f"P{i}"] = {
            "name": f"P{i}",
            "kind": "position",
            "components": [f"P{i} X", f"P{i} Y"],
            "axes": ["X", "Y"],
            "diameter": float(rng.choice([0.004, 0.006])),
            "features": {f"F{i + 3}": 1},
        }
    model = model_from_dict(
        {
            "process": {"name": "half", "axes": ["X", "Y"], "resolution": RES, "limit": 4 * RES},
            "wks": {"W1": {"register": "G54"}},
            "features": features,
            "dimensions": dims,
        }
    )
    values = {n: float(rng.integers(-6, 7)) * RES / 2 for d in dims.values() for n in d.get("components", [d["name"]])}
    table = pd.DataFrame({"characteristic": list(values), "deviation": list(values.values()), "unit": "mm"})
    (part,) = match_parts(model, table)
    return CorrectionProblem.from_part(model, part)


@pytest.mark.parametrize("seed", range(16))
def test_leximin_counts_a_zone_once(seed: int) -> None:
    problem = zone_problem(seed, spread=0.004)
    want = brute(problem)
    result = get_optimizer("exact").solve(problem)
    _check(problem, result, want)
    if not want.gone:  # the levels are per dimension: as many as the dimensions (a zone once)
        assert sum(c for _, c in result.leximin) == len(want.ids)


@pytest.fixture(params=list(TRIAGE_PATHS))
def path(request: pytest.FixtureRequest) -> str:
    """Every way of the triage (as in test_exact_triage): listing, the forced kept set, the MILPs."""
    return str(request.param)


@pytest.mark.parametrize("seed", range(12))
def test_triage_keeps_or_gives_up_whole_zones(seed: int, path: str) -> None:
    problem = zone_problem(100 + seed, spread=0.009)
    want = brute(problem)
    result = get_optimizer("exact", time_limit=30.0, settings=TRIAGE_PATHS[path]).solve(problem)
    _check(problem, result, want)


@pytest.mark.parametrize("seed", [22, 124, 125, 215, 263, 267, 280, 283, *range(8)])
def test_half_step_ties_and_conflicts_against_brute_force(seed: int) -> None:
    """Exact ties and a discrete conflict (seed 280 opens branches); seeds 22 … 283 are near-ties below the
    input quantum, decided by the rounded deviations the optimiser documents."""
    problem = half_step_problem(seed)
    result = get_optimizer("exact", time_limit=30.0).solve(problem)
    _check(problem, result, brute(problem))
    if seed == 280:
        assert "branch:" in result.path


def test_generated_triage_cases_give_up_zones() -> None:
    """The generator reaches what the tests are for: triage cases, and zones given up and kept among them."""
    gone = [brute(zone_problem(100 + s, spread=0.009)).gone for s in range(12)]
    assert sum(bool(g) for g in gone) >= 6
    assert any(d.startswith("P") for g in gone for d in g)
    assert any(g and not all(d.startswith("P") for d in g) for g in gone)


def test_one_axis_problems_keep_one_dimension_per_column() -> None:
    from .test_exact import random_problem

    problem = random_problem(3, n=3, m=7, limit_steps=2, spread=0.3)
    ids, column_dim = model_dimensions(problem)
    assert ids == problem.dimension_ids and column_dim.tolist() == list(range(7))
    upper, lower = np.isfinite(problem.upper), np.isfinite(problem.lower)
    assert dimension_of_rows(problem).tolist() == [*np.flatnonzero(upper), *np.flatnonzero(lower)]
    assert np.array_equal(dimension_floor(problem), problem.held_floor)
    x = problem.snap(np.full(3, 0.002))
    inside = (problem.deviation >= problem.lower) & (problem.deviation <= problem.upper)
    assert np.array_equal(harmed_columns(problem, x), inside & (problem.margins(x) < -1e-12))


def test_zone_harm_is_judged_on_the_zone() -> None:
    """A zone measured outside its circle cannot be harmed, whatever its facets do; one inside can."""
    problem = zone_problem(7)
    assert problem.circles is not None and problem.rows is not None
    inside = problem.circles.margins(np.zeros(problem.n_registers)) >= 0
    for x in _grid(problem)[::37] * RES:
        harmed = harmed_columns(problem, x)
        circle_after = problem.circles.margins(x)
        for z, (d, was_in) in enumerate(zip(problem.circles.ids, inside, strict=True)):
            cols = np.array([r == d for r in problem.rows])
            facets = problem.margins(x)[cols]
            if not was_in:
                assert not harmed[cols].any()
            elif facets.min() < min(0.0, problem.margins(np.zeros_like(x))[cols].min()) - 1e-12:
                assert harmed[cols].any()
            else:
                assert not harmed[cols].any() and circle_after[z] >= facets.min() - 1e-12


# --- against an independent lexicographic solver (tests/optimize/leximin_reference.py) ------------------------

SAMPLE = Path(__file__).resolve().parents[2] / "sample_reports" / "two_station_xyz"


@pytest.mark.slow
def test_sample_leximin_equals_an_independent_solver_on_its_rows() -> None:
    """two_station_xyz cycle 1 (11 registers, 4 zones of 18–19 facets): the whole leximin vector over the
    16 dimensions (a zone once) equals scipy's stage-by-stage optimum on the same rows."""
    from setupfix.inputs.cycles import load_parts
    from setupfix.model import load_model

    model = load_model(SAMPLE / "model.toml")
    problem = CorrectionProblem.from_part(model, load_parts(model, SAMPLE / "cycle_01.csv")[0])
    g_rows, g = margin_rows(problem)
    row_dim = dimension_of_rows(problem)
    n_dims = len(model_dimensions(problem)[0])
    free = problem.free
    sums, _ = lexicographic_maxmin(
        g_rows, g, row_dim, n_dims, problem.kmin[free].astype(float), problem.kmax[free].astype(float)
    )
    result = get_optimizer("exact", time_limit=60.0).solve(problem)  # a loaded test box; the bench times 2 s
    assert result.status == "optimal"
    k = result.x[free] / problem.resolution
    assert n_dims == 16 and sum(c for _, c in result.leximin) == 16
    m = np.full(n_dims, np.inf)
    np.minimum.at(m, row_dim, g - g_rows @ k)
    assert prefix_sums(m) == pytest.approx(sums, abs=1e-4)  # steps; ties within the quantum


def _circle_rows(fx: Fixture, sides: int = 720) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fixture's true margins in µm per register step, a zone as a 720-gon of its circle (error ≤ 1 nm
    here): margin = R − n_j·v / cos(π/K) for each facet j, written from the fixture, not from setupfix."""
    a, b, row_dim = [], [], []
    c = np.cos(np.pi / sides)
    for q, d in enumerate(fx.dims):
        if d["kind"] == "position":
            ang = 2 * np.pi * np.arange(sides) / sides
            normals = np.stack([np.cos(ang), np.sin(ang)], axis=1)
            a.append((normals @ d["columns"].T) * fx.steps / c)
            b.append(d["diameter"] / 2 - normals @ d["deviation"] / c)
            row_dim += [q] * sides
        else:
            col = d["column"] * fx.steps
            a.append(np.stack([-col, col]))
            b.append(np.array([d["deviation"] - d["lower"], d["upper"] - d["deviation"]]))
            row_dim += [q, q]
    return np.vstack(a) * 1e3, np.concatenate(b) * 1e3, np.array(row_dim)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fixture_leximin_against_an_independent_solver_on_the_circles(tmp_path: Path, seed: int) -> None:
    """Held-out multi-axis fixtures: our sorted TRUE margins (circles) against scipy's lexicographic optimum
    of the circles.  Ours is exact on polygons within ``problem.polygon`` (≤ 1 µm) of the circles, so at the
    first position where the two sorted vectors differ by more than that bound, ours must be the larger."""
    from multi_axis_fixtures import make_fixture, report_csv, true_margins

    from setupfix.inputs.cycles import load_parts
    from setupfix.model import load_model

    fx = make_fixture(seed)
    (tmp_path / "model.toml").write_text(fx.text, encoding="utf-8")
    (tmp_path / "report.csv").write_text(report_csv(fx), encoding="utf-8")
    model = load_model(tmp_path / "model.toml")
    problem = CorrectionProblem.from_part(model, load_parts(model, tmp_path / "report.csv")[0])
    result = get_optimizer("exact", time_limit=60.0).solve(problem)
    assert result.status == "optimal"
    ours = np.sort(true_margins(fx, problem.register_values(result.x))) * 1e3  # µm
    a, b, row_dim = _circle_rows(fx)
    kmax = np.floor(fx.limits / fx.steps + 1e-9)
    sums, k_ref = lexicographic_maxmin(a, b, row_dim, len(fx.dims), -kmax, kmax)
    ref = np.sort(true_margins(fx, k_ref * fx.steps)) * 1e3
    assert np.cumsum(ref) == pytest.approx(sums, abs=1e-3)  # the reference's point reaches its sums
    bound = problem.polygon * 1e3 + 1e-3  # µm
    apart = np.flatnonzero(np.abs(ours - ref) > bound)
    assert apart.size == 0 or ours[apart[0]] > ref[apart[0]], (ours, ref)
    assert ours[0] >= ref[0] - bound  # the paper's δ (leximin's first level) on the circles


def test_zone_inside_its_circle_but_outside_its_polygon_is_held() -> None:
    """δ = (0.0499, 0) in a zone of radius 0.05: inside the circle (margin +0.1 µm), outside the inscribed
    polygon (its facet at angle 0 is at R·cos(π/k)).  It is held (no harm) at its polygon margin before, not
    given up; a length A out of reach forces the triage."""
    model = model_from_dict(
        {
            "process": {"name": "edge", "axes": ["X", "Y"], "resolution": RES, "limit": 3 * RES},
            "wks": {"W1": {"register": "G54"}},
            "features": {"F1": {"wks": {"W1": 1}}, "F2": {"wks": {"W1": 1}}},
            "dimensions": {
                "A": {"name": "A", "axis": "X", "features": {"F1": 1}, "nominal": 0, "lower": -0.01, "upper": 0.01},
                "H": {
                    "name": "H",
                    "kind": "position",
                    "components": ["H X", "H Y"],
                    "axes": ["X", "Y"],
                    "diameter": 0.1,
                    "features": {"F2": 1},
                },
            },
        }
    )
    table = pd.DataFrame({"characteristic": ["A", "H X", "H Y"], "deviation": [0.02, 0.0499, 0.0], "unit": "mm"})
    (part,) = match_parts(model, table)
    problem = CorrectionProblem.from_part(model, part)
    assert problem.circles is not None and problem.circles.margins(np.zeros(2))[0] == pytest.approx(1e-4)
    floor = dimension_floor(problem)
    polygon_before = problem.margins(np.zeros(2))[1:].min()
    assert polygon_before < 0 and floor[1] == pytest.approx(polygon_before)  # held at its polygon margin
    assert floor[0] == -np.inf  # A is out: not held
    want = brute(problem)
    result = get_optimizer("exact").solve(problem)
    _check(problem, result, want)
    assert want.gone == ("A",)
    assert not harmed_columns(problem, result.x).any()
