"""ISO 14253-1 verdicts against an independent computation, brute force over a grid.

Values, limits and U are whole micrometres held as floats (exact), so the independent rule is
written in integers: conforming when the distance to each limit is at least U, nonconforming
when the value lies beyond a limit by more than U, not proven otherwise.
"""

from __future__ import annotations

import itertools
import tomllib
from pathlib import Path

import numpy as np
import pytest

from setupfix.correction.conformance import (
    conformance_codes,
    conformance_names,
    conformance_rows,
    dimension_uncertainty,
    report_uncertainty,
)
from setupfix.model import PartMeasurement, model_from_dict

INF = 10**9  # an absent limit, in the integer rule


def independent(v: int, lo: int, up: int, u: int, zone: bool = False) -> str:
    """The verdict by the standard's wording, in integers (INF: a one-sided tolerance)."""
    if zone:
        lo = -INF
    below = lo - v  # > 0: beyond the lower limit by this much
    above = v - up
    if max(below, above) > u:
        return "nonconforming"
    if min(v - lo, up - v) >= u:
        return "conforming"
    return "not_proven"


def as_float(limit: int) -> float:
    return float("inf") if limit == INF else float("-inf") if limit == -INF else float(limit)


LIMITS = [(-10, 10), (-4, 6), (0, 3), (-INF, 5), (-5, INF)]


def test_every_verdict_on_a_grid_matches_the_independent_rule() -> None:
    values = list(range(-20, 21))
    us = [0, 1, 2, 3, 5, 6]
    for (lo, up), u in itertools.product(LIMITS, us):
        got = conformance_names(
            conformance_codes(
                np.array(values, float),
                np.full(len(values), as_float(lo)),
                np.full(len(values), as_float(up)),
                float(u),
            )
        )
        want = [independent(v, lo, up, u) for v in values]
        assert got == want, (lo, up, u)


def test_broadcast_over_parts_and_per_dimension_u() -> None:
    rng = np.random.default_rng(7)
    v = rng.integers(-15, 16, size=(50, 4)).astype(float)
    lo = np.array([-10.0, -4.0, 0.0, -np.inf])
    up = np.array([10.0, 6.0, 3.0, 5.0])
    u = np.array([2.0, 0.0, 1.0, 3.0])
    codes = conformance_codes(v, lo, up, u)
    names = ["conforming", "not_proven", "nonconforming"]
    for i, j in itertools.product(range(50), range(4)):
        lim = -INF if not np.isfinite(lo[j]) else int(lo[j])
        assert names[codes[i, j]] == independent(int(v[i, j]), lim, int(up[j]), int(u[j]))


def test_zone_judged_on_its_radius() -> None:
    r = np.arange(0, 16, dtype=float)
    codes = conformance_codes(r, np.zeros(16), np.full(16, 10.0), 2.0, zone=np.ones(16, dtype=bool))
    want = [independent(int(x), 0, 10, 2, zone=True) for x in r]
    assert conformance_names(codes) == want
    assert want[0] == "conforming"  # the centre of a zone is no limit


def test_without_u_conforming_is_in_tolerance() -> None:
    v = np.linspace(-0.2, 0.2, 401)
    codes = conformance_codes(v, -0.1, 0.1, 0.0)
    inside = (v >= -0.1 - 1e-12) & (v <= 0.1 + 1e-12)
    assert np.array_equal(codes == 0, inside) and np.array_equal(codes == 2, ~inside)


def test_not_measured_is_empty() -> None:
    assert conformance_names(conformance_codes(np.array([np.nan, 0.0]), -1.0, 1.0, 0.1)) == ["", "conforming"]


MODEL = {
    "process": {"name": "p"},
    "measurement": {"uncertainty": 0.004},
    "wks": {"W1": {"register": "G54"}},
    "features": {"F1": {"wks": {"W1": 1}}},
    "dimensions": {
        "D1": {"features": {"F1": 1}, "nominal": 10.0, "lower": -0.05, "upper": 0.05},
        "D2": {"features": {"F1": 1}, "nominal": 20.0, "lower": -0.05, "upper": 0.05, "uncertainty": 0.002},
    },
}


def part(deviation: list[float], u: list[float] | None = None) -> PartMeasurement:
    d = np.array(deviation, float)
    given = None if u is None else np.array(u, float)
    return PartMeasurement(part="1", report="r", timestamp=None, deviation=d, sources=("", ""), uncertainty=given)


def test_report_u_wins_over_the_models() -> None:
    model = model_from_dict(MODEL)
    u, src = dimension_uncertainty(model)
    assert u.tolist() == [0.004, 0.002] and src == ("measurement", "dimension")
    u, src = dimension_uncertainty(model, part([0.0, 0.0], [0.001, np.nan]))
    assert u.tolist() == [0.001, 0.002] and src == ("report", "dimension")
    assert report_uncertainty(part([0.0, 0.0])) is None
    assert report_uncertainty(part([0.0, 0.0], [np.nan, np.nan])) is None


def test_inside_the_tolerance_within_u_of_a_limit_is_not_proven() -> None:
    # issue 40, done when: the report carries U; D1 at 0.048 is inside ±0.05 but within U = 0.003 of the limit
    model = model_from_dict(MODEL)
    rows = [
        {"id": "D1", "deviation": 0.048, "predicted": 0.0},
        {"id": "D2", "deviation": -0.0485, "predicted": -0.0515},
    ]
    out = conformance_rows(model, part([0.048, -0.0485], [0.003, np.nan]), rows)
    assert [r["conformance_before"] for r in out] == ["not_proven", "not_proven"]
    assert [r["conformance_after"] for r in out] == ["conforming", "not_proven"]
    assert [r["uncertainty_source"] for r in out] == ["report", "dimension"]
    assert out[0]["uncertainty"] == 0.003
    out = conformance_rows(model, part([0.048, -0.06]), [{"id": "D2", "deviation": -0.06, "predicted": 0.0}])
    assert out[0]["conformance_before"] == "nonconforming"


@pytest.mark.parametrize("u", [0.0, 0.01])
def test_rows_of_the_correct_use_case_carry_the_verdicts(u: float) -> None:
    from setupfix.usecases.correct import correct_cycle
    from setupfix.usecases.requests import CorrectRequest

    doc = {**MODEL, "measurement": {"uncertainty": u}}
    doc["dimensions"] = {"D1": dict(MODEL["dimensions"]["D1"])}  # type: ignore[index]
    model = model_from_dict(doc)
    p = PartMeasurement(part="1", report="r", timestamp=None, deviation=np.array([0.045]), sources=("",))
    rows = correct_cycle(CorrectRequest(model), p).dimension_rows()
    assert rows[0]["conformance_before"] == ("conforming" if u == 0 else "not_proven")
    assert rows[0]["conformance_after"] == "conforming"
    assert rows[0]["uncertainty"] == u


def test_a_report_carrying_u_makes_a_value_near_a_limit_not_proven(tmp_path: Path) -> None:
    # issue 40, done when: the report's own U (canonical column) decides; inside ±0.1 at 0.0955, U 0.008
    from setupfix.usecases.correct import correct_report, load_request

    report = tmp_path / "r.csv"
    report.write_text(
        "characteristic,nominal,actual,deviation,lower,upper,unit,part,uncertainty\n"
        "P1 D1,25.0,25.0955,0.0955,-0.1,0.1,mm,1,0.008\n"
        "P1 D2,40.0,40.02,0.02,-0.1,0.1,mm,1,\n",
        encoding="utf-8",
    )
    model = model_from_dict(
        {
            "process": {"name": "p"},
            "measurement": {"uncertainty": 0.001},
            "wks": {"W1": {"register": "G54"}},
            "tools": {"T1": {"register": "H1"}},
            "features": {"F1": {"wks": {"W1": 1}}, "F2": {"tools": {"T1": 1}}},
            "dimensions": {
                "D1": {"name": "P1 D1", "features": {"F1": 1}, "nominal": 25.0, "lower": -0.1, "upper": 0.1},
                "D2": {"name": "P1 D2", "features": {"F2": 1}, "nominal": 40.0, "lower": -0.1, "upper": 0.1},
            },
        }
    )
    (cycle,) = correct_report(load_request(model), report).cycles
    rows = {r["id"]: r for r in cycle.dimension_rows()}
    assert rows["D1"]["conformance_before"] == "not_proven" and rows["D1"]["uncertainty_source"] == "report"
    assert rows["D1"]["uncertainty"] == 0.008 and rows["D1"]["conformance_after"] == "conforming"
    assert rows["D2"]["uncertainty_source"] == "measurement" and rows["D2"]["conformance_before"] == "conforming"
    # the guard band used the report's U: the solved limits of D1 are ±(0.1 − 0.008)
    guarded = cycle.recommendation.problem
    at = guarded.dimension_ids.index("D1")
    assert guarded.upper[at] == pytest.approx(0.092) and guarded.lower[at] == pytest.approx(-0.092)


@pytest.mark.parametrize("u", [0.0, 0.01])
def test_text_and_page_show_u_only_where_given(u: float) -> None:
    from setupfix.usecases.correct import correct_cycle
    from setupfix.usecases.requests import CorrectRequest
    from setupfix.views.html import correction_page
    from setupfix.views.present import format_correction

    doc = {**MODEL, "measurement": {"uncertainty": u}}
    doc["dimensions"] = {"D1": dict(MODEL["dimensions"]["D1"])}  # type: ignore[index]
    p = PartMeasurement(part="1", report="r", timestamp=None, deviation=np.array([0.045]), sources=("",))
    cycle = correct_cycle(CorrectRequest(model_from_dict(doc)), p)
    text = format_correction(cycle)
    page = correction_page(cycle)
    if u:
        assert "U 0.0100 (model)  not proven → conforming" in text
        assert "ISO 14253-1 before" in page and "not proven" in page
    else:
        assert "ISO 14253-1" not in text and "ISO 14253-1 before" not in page


def independent_float(v: float, lo: float, up: float, u: float, zone: bool) -> str:
    lo = -np.inf if zone else lo
    if v < lo - u - 1e-12 or v > up + u + 1e-12:
        return "nonconforming"
    if lo + u - 1e-12 <= v <= up - u + 1e-12:
        return "conforming"
    return "not_proven"


@pytest.mark.slow
def test_every_row_of_a_multi_axis_sample_with_zones() -> None:
    from setupfix.usecases.correct import correct_report, load_request

    root = Path(__file__).resolve().parents[2] / "sample_reports" / "two_station_xyz"
    text = (root / "model.toml").read_text(encoding="utf-8")
    doc = tomllib.loads(text)
    doc["measurement"] = {"mpe": [5.0, 100]}  # large enough to leave some rows not proven
    model = model_from_dict(doc)
    verdicts = set()
    for cycle in correct_report(load_request(model), root / "cycle_01.csv").cycles:
        rows = cycle.dimension_rows()
        dims = {d.id: d for d in model.dimensions}
        assert any(dims[r["id"]].zone for r in rows)
        for r in rows:
            d = dims[r["id"]]
            u = (5.0 + abs(d.nominal) / 100) / 1000
            assert r["uncertainty"] == pytest.approx(u) and r["uncertainty_source"] == "mpe"
            lo, up = (0.0, d.upper) if d.zone else (d.lower, d.upper)
            for key, value in (("conformance_before", r["deviation"]), ("conformance_after", r["predicted"])):
                assert r[key] == independent_float(value, lo, up, u, d.zone), (r["name"], key)
                verdicts.add(r[key])
    assert "not_proven" in verdicts and "conforming" in verdicts


def test_the_papers_objective_stays_available_with_guard_band_zero() -> None:
    # guard_band = 0: solved on the tolerance itself (the paper's objective), verdicts still with the full U
    from setupfix.usecases.correct import correct_cycle
    from setupfix.usecases.requests import CorrectRequest

    def solve(extra: dict[str, object]) -> tuple[dict[str, float], list[dict[str, object]]]:
        doc = {**MODEL, **extra}
        doc["dimensions"] = {"D1": dict(MODEL["dimensions"]["D1"])}  # type: ignore[index]
        p = PartMeasurement(part="1", report="r", timestamp=None, deviation=np.array([0.048]), sources=("",))
        cycle = correct_cycle(CorrectRequest(model_from_dict(doc)), p)
        return cycle.corrections, cycle.dimension_rows()

    plain, _ = solve({"measurement": {"uncertainty": 0.0}})
    paper, rows = solve({"measurement": {"uncertainty": 0.01}, "safety": {"guard_band": 0.0}})
    assert paper == plain and "guard_band" not in str(rows)
    assert rows[0]["conformance_before"] == "not_proven" and rows[0]["uncertainty"] == 0.01
