"""setupfix.correction.pose: the one problem builder, step by step, against the formulas and brute force."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pytest

from setupfix.correction.ewma import ewma_history
from setupfix.correction.pose import pose_problem
from setupfix.correction.recommend import recommend
from setupfix.correction.relation import relation_matrices
from setupfix.diagnose.forecast import forecast_shift
from setupfix.diagnose.terms import Layout
from setupfix.model import PartMeasurement, ProcessModel, model_from_dict
from setupfix.optimize import CorrectionProblem, get_optimizer

if TYPE_CHECKING:
    from setupfix.usecases.requests import CycleCorrection

SOLVE = get_optimizer("exact").solve
#: A model document's table, as model_from_dict reads it.
Doc = dict[str, Any]


def model(
    safety: Doc | None = None,
    w1: Doc | None = None,
    w2: Doc | None = None,
    t5: Doc | None = None,
    effects: Doc | None = None,
) -> ProcessModel:
    """Two WKS and a tool on two dimensions; W1 and W2 move D1 alike (a null space of x1 − x2)."""
    doc: Doc = {
        "process": {"name": "p", "resolution": 0.001, "limit": 0.02},
        "wks": {"W1": {"register": "G54", **(w1 or {})}, "W2": {"register": "G55", **(w2 or {})}},
        "tools": {"T5": {"register": "H5", **(t5 or {})}},
        "features": {"F1": {"wks": {"W1": 1, "W2": 1}}, "F2": {"tools": {"T5": 1}}},
        "dimensions": {
            "D1": {"features": {"F1": 1}, "nominal": 10, "lower": -0.01, "upper": 0.01},
            "D2": {"features": {"F2": 1}, "nominal": 5, "lower": -0.02, "upper": 0.02},
        },
    }
    if safety:
        doc["safety"] = safety
    if effects:
        doc["effects"] = effects
    return model_from_dict(doc)


def part(m: ProcessModel, deviation: npt.ArrayLike, timestamp: str | None = None, name: str = "A1") -> PartMeasurement:
    dev = np.asarray(deviation, dtype=float)
    return PartMeasurement(
        part=name, report="r.csv", timestamp=timestamp, deviation=dev, sources=tuple("" for _ in dev)
    )


def brute_force(problem: CorrectionProblem) -> tuple[float, npt.NDArray[np.float64]]:
    """Every grid point: the best f1 (eq. 8), then the least Σ cost·x² among those (eq. 9 weighted)."""
    axes = [np.arange(k0, k1 + 1) * problem.resolution for k0, k1 in zip(problem.kmin, problem.kmax, strict=True)]
    grid = np.array(list(itertools.product(*axes)))
    f1 = problem.evaluate(grid)[0]
    best = grid[f1 >= f1.max() - 1e-12]
    weighted = (best**2 * problem.cost).sum(axis=1)
    return f1.max(), best[weighted <= weighted.min() + 1e-15]


@pytest.mark.parametrize("costs", [(1.0, 1.0), (4.0, 1.0), (1.0, 9.0), (0.25, 1.0)])
def test_costs_pick_the_least_weighted_norm_as_brute_force_says(costs: tuple[float, float]) -> None:
    m = model(w1={"cost": costs[0]}, w2={"cost": costs[1]})
    posed = pose_problem(m, part(m, [0.008, 0.0]))
    np.testing.assert_array_equal(posed.problem.cost, [costs[0], costs[1], 1.0])
    np.testing.assert_array_equal(CorrectionProblem.from_part(m, part(m, [0.008, 0.0])).cost, posed.problem.cost)
    f1, picks = brute_force(posed.guarded)
    result = SOLVE(posed.guarded)
    assert result.margin_after == pytest.approx(f1, abs=1e-12)
    assert any(np.allclose(result.x, p, atol=1e-12) for p in picks), (result.x, picks)
    # the cheaper WKS moves more: x_i ∝ 1/cost_i on the line x1 + x2 = −0.008
    if costs[0] != costs[1]:
        cheap = int(np.argmin(costs))
        assert abs(result.x[cheap]) > abs(result.x[1 - cheap])


def test_ewma_equals_the_formula_with_corrections_and_a_tool_change() -> None:
    m = model()
    C = relation_matrices(m).composite
    t = np.array(
        ["2026-01-01T08:00", "2026-01-01T09:00", "2026-01-01T07:00", "2026-01-01T11:00"], dtype="datetime64[ns]"
    )
    earlier = np.array([[0.004, 0.010], [0.006, 0.012], [0.002, 0.008], [0.5, 0.5]])  # the last is later: out
    log_t = np.array(["2026-01-01T08:30", "2026-01-01T09:30"], dtype="datetime64[ns]")
    now = np.datetime64("2026-01-01T10:00", "ns")
    y = np.array([0.007, 0.011])
    lam = 0.4
    got = ewma_history(
        y, now, t, earlier, log_t, np.array([0, 2]), np.array([-0.003, 0.0]), np.array([False, True]), C, lam
    )
    # in time order 07:00, 08:00, 09:00; W1 −0.003 at 08:30 shifts the first two on D1; T5 changed at 09:30: D2 reset
    rows = [earlier[2] + np.array([-0.003, 0.0]), earlier[0] + np.array([-0.003, 0.0]), earlier[1]]
    a = np.array([rows[0][0], np.nan])
    for r in rows[1:]:
        a = np.array([lam * r[0] + (1 - lam) * a[0], np.nan])
    want = np.array([lam * y[0] + (1 - lam) * a[0], y[1]])  # D2: every earlier value reset, the cycle alone
    assert got.used == 3
    np.testing.assert_allclose(got.deviation, want, atol=1e-15)
    posed = pose_problem(m, part(m, y), smoothed=got)
    np.testing.assert_allclose(posed.problem.deviation, want)
    np.testing.assert_array_equal(posed.measured, y)
    assert [e.rule for e in posed.effects] == ["ewma"] and posed.estimated


def test_forecast_equals_forecast_shift_and_relations_replace_the_composite() -> None:
    effects = {
        "origin": "2026-01-01T06:00:00",
        "cycle_hours": 0.5,
        "last_hours": 1.0,
        "E1": {"kind": "drift", "estimate": 0.004, "unit": "mm/h"},
        "E2": {"kind": "wear", "register": "T5", "estimate": -0.0005},
        "E3": {"kind": "relation", "register": "W1", "dimension": "D1", "estimate": 0.5},
    }
    m = model(effects=effects)
    y = np.array([0.003, -0.004])
    posed = pose_problem(m, part(m, y, timestamp="2026-01-01T08:00:00"))
    shift = forecast_shift(m.effects, Layout.from_model(m), time=2.0)
    assert shift.any()
    np.testing.assert_allclose(posed.problem.deviation, y + shift, atol=1e-15)
    np.testing.assert_array_equal(posed.measured, y)
    C = relation_matrices(m).composite.copy()
    C[0, 0] += 0.5
    np.testing.assert_array_equal(posed.problem.composite, C)
    assert [e.rule for e in posed.effects] == ["forecast"]
    assert posed.effects[0].dimensions == ("D2",)  # drift and wear of the tool: only its dimension moves
    assert [n.kind for n in posed.notes] == ["forecast", "relation"]
    given = np.ones_like(C)  # a composite given by the caller (the diagnosis's) wins over the relations
    np.testing.assert_array_equal(pose_problem(m, part(m, y), composite=given).problem.composite, given)


def test_guard_band_cumulative_bounds_and_fixed_registers_in_order() -> None:
    m = model(
        safety={"uncertainty": 0.002, "guard_band": 0.5, "cumulative_limit": 0.005},
        w2={"cost": 2.0},
        t5={"offset": "wear"},
    )
    m = m.__class__(
        **{
            **{f: getattr(m, f) for f in m.__dataclass_fields__},
            "wks": (
                m.wks[0],
                type(m.wks[1])(**{**{f: getattr(m.wks[1], f) for f in m.wks[1].__dataclass_fields__}, "fixed": True}),
            ),
        }
    )
    posed = pose_problem(m, part(m, [0.009, -0.015]), cumulative={"T5": -0.003})
    np.testing.assert_allclose(posed.guarded.lower, [-0.009, -0.019])
    np.testing.assert_allclose(posed.guarded.upper, [0.009, 0.019])
    np.testing.assert_allclose(posed.problem.lower, [-0.01, -0.02])  # the real limits stay for every number shown
    np.testing.assert_allclose(posed.guarded.lb, [-0.02, 0.0, -0.002])  # T5: |−0.003 + x| ≤ 0.005
    np.testing.assert_allclose(posed.guarded.ub, [0.02, 0.0, 0.008])
    np.testing.assert_array_equal(posed.guarded.cost, [1.0, 2.0, 1.0])
    assert [e.rule for e in posed.effects] == ["guard_band", "cumulative_limit"]
    rec = recommend(posed, SOLVE)
    assert rec.x[1] == 0.0 and rec.problem is posed.guarded
    assert [r.rule for r in rec.rules][:2] == ["guard_band", "cumulative_limit"]


def test_reject_judges_the_part_as_measured_not_the_estimate() -> None:
    m = model(safety={"reject_band": 0.005})
    y = np.array([0.02, 0.0])  # 0.01 beyond D1's upper limit: beyond the reject band
    posed = pose_problem(m, part(m, y))
    rec = recommend(posed, SOLVE)
    assert rec.verdict == "reject" and [r.rule for r in rec.rules] == ["reject"] and not rec.x.any()


# -- coverage: registers that move a dimension the report lacks -----------------------------------------------------

from conftest import GUIDE_PINS  # noqa: E402

TRUNCATED = ("P2 D1", "P2 D2", "P2 D3", "P2 D4")  # half of station P2's seven dimensions


def truncated_copy(tmp_path: Path, name: str = "cycle_02.csv", drop: tuple[str, ...] = TRUNCATED) -> Path:
    lines = (GUIDE_PINS / name).read_text(encoding="utf-8").splitlines(keepends=True)
    out = tmp_path / f"truncated_{name}"
    out.write_text("".join(li for li in lines if not li.startswith(tuple(f"{d}," for d in drop))), encoding="utf-8")
    return out


def corrected(report: Path, model_path: Path = GUIDE_PINS / "model.toml", **inputs: Any) -> CycleCorrection:
    from setupfix.usecases.correct import correct_report, load_request

    (cycle,) = correct_report(load_request(model_path, **inputs), report).cycles
    return cycle


def moving(cycle: CycleCorrection, dims: tuple[str, ...]) -> set[str]:
    """Register IDs whose composite column moves any of ``dims`` (names), from the model's relation matrices."""
    rm = relation_matrices(cycle.model)
    cols = [i for i, d in enumerate(cycle.model.dimensions) if d.name in dims]
    return {r for r, row in zip(rm.registers, rm.composite, strict=True) if np.any(row[cols] != 0)}


def test_a_truncated_report_holds_every_register_that_moves_a_missing_dimension(tmp_path: Path) -> None:
    full = corrected(GUIDE_PINS / "cycle_02.csv")
    cycle = corrected(truncated_copy(tmp_path))
    held = moving(cycle, TRUNCATED)
    assert {"W2", "W6"} <= held
    assert any(full.corrections[r] != 0 for r in held)  # the whole report moves some of them …
    assert all(cycle.corrections[r] == 0 for r in held)  # … the truncated one none
    (rule,) = [r for r in cycle.recommendation.rules if r.rule == "coverage"]
    assert set(rule.registers) == held and {cycle.model.dimensions[i].id for i in range(7, 11)} == set(rule.dimensions)
    assert "G55" in rule.message and "P2 D1" in rule.message
    if cycle.verdict == "apply":  # the other registers are still corrected
        assert any(v != 0 for r, v in cycle.corrections.items() if r not in held)


def test_a_dimension_marked_sampled_leaves_its_registers_free(tmp_path: Path) -> None:
    text = (GUIDE_PINS / "model.toml").read_text(encoding="utf-8")
    assert "[template.dimensions.D1]" in text
    for d in ("D1", "D2", "D3", "D4"):
        text = text.replace(f"[template.dimensions.{d}]\n", f"[template.dimensions.{d}]\nsampled = true\n")
    model_path = tmp_path / "model.toml"
    model_path.write_text(text, encoding="utf-8")
    cycle = corrected(truncated_copy(tmp_path), model_path)
    assert "coverage" not in [r.rule for r in cycle.recommendation.rules]
    assert all(d.sampled == (d.id[-2:] in ("D1", "D2", "D3", "D4")) for d in cycle.model.dimensions)
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("sampled = true", 'sampled = "yes"', 1), encoding="utf-8")
    from setupfix.core.errors import SetupfixError
    from setupfix.model import load_model

    with pytest.raises(SetupfixError, match="sampled"):
        load_model(bad)


def test_a_recent_measurement_in_the_history_stands_in_moved_by_the_corrections_since(tmp_path: Path) -> None:
    import contextlib
    import io

    from setupfix.cli import main

    db = tmp_path / "history.db"
    log = tmp_path / "corrections.csv"  # G55 moved by +0.010 between cycle 01 and cycle 02
    log.write_text("timestamp,register,delta,event\n2026-11-02T12:00:00,G55,0.010,correction\n", encoding="utf-8")
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
        code = main(
            [
                "history",
                "import",
                "--db",
                str(db),
                "--model",
                str(GUIDE_PINS / "model.toml"),
                str(GUIDE_PINS / "cycle_01.csv"),
                "--corrections",
                str(log),
            ]
        )
    assert code == 0, err.getvalue()
    cycle = corrected(truncated_copy(tmp_path), store=db)
    rules = {r.rule: r for r in cycle.recommendation.rules}
    assert "coverage" not in rules and len(rules["stand_in"].dimensions) == 4
    first = corrected(GUIDE_PINS / "cycle_01.csv")
    model = cycle.model
    rm = relation_matrices(model)
    w2 = rm.composite[rm.registers.index("W2")]
    ids = list(cycle.problem.dimension_ids)
    for did in rules["stand_in"].dimensions:
        q = [d.id for d in model.dimensions].index(did)
        before = first.problem.deviation[list(first.problem.dimension_ids).index(did)]
        assert cycle.problem.deviation[ids.index(did)] == pytest.approx(before + 0.010 * w2[q])
