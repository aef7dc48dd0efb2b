"""Presentation rows: symbols, bars, sorting, match suggestions, convergence, the offsets text."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import GUIDE_PINS

from setupfix.model import ProcessModel, load_model
from setupfix.usecases.compare import compare_problem
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, SolveOptions
from setupfix.views import analysis as analysis_view
from setupfix.views import correction as view

#: The README's cycle-1 numbers are the paper's objective's (issue 22 made leximin the default).
REQUEST = CorrectRequest(load_model(GUIDE_PINS / "model.toml"), solve=SolveOptions(objective="paper"))


@pytest.fixture(scope="module")
def correction() -> CycleCorrection:
    return correct_report(REQUEST, GUIDE_PINS / "cycle_01.csv").cycles[0]


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (0.0, "├────┼────┤".replace("┼", "●")),
        (-0.1, "●────┼────┤"),
        (0.1, "├────┼────●"),
        (-0.2, "◀────┼────┤"),
        (0.2, "├────┼────▶"),
        (0.05, "├────┼──●─┤"),
        (-0.05, "├─●──┼────┤"),
        (math.nan, "├────┼────┤"),
    ],
)
def test_zone_bar_marks_the_value_in_the_tolerance_zone(value: float, expected: str) -> None:
    assert view.zone_bar(value, -0.1, 0.1, 11) == expected


def test_zone_bar_of_a_one_sided_tolerance_is_symmetric_about_nominal() -> None:
    assert view.zone_bar(-0.05, -math.inf, 0.1, 11) == view.zone_bar(-0.05, -0.1, 0.1, 11)
    assert view.zone_bar(0.2, -math.inf, 0.1, 11).endswith("▶")


def test_dimension_rows_carry_the_correction_and_its_symbols(correction: CycleCorrection) -> None:
    rows = view.dimension_rows(correction)
    assert len(rows) == 28 and [r.id for r in rows] == list(correction.problem.dimension_ids)
    pred = correction.problem.predicted(correction.x)
    np.testing.assert_allclose([r.predicted for r in rows], pred)
    assert min(r.margin_before for r in rows) == pytest.approx(correction.result.margin_before)
    assert min(r.margin_after for r in rows) == pytest.approx(correction.margin_after)
    assert {r.name for r in rows if view.BINDING in r.flags} == {"P1 D6", "P1 D7"}
    assert all(r.flags.startswith("✓✓") for r in rows)
    assert view.stations(rows) == ["P1", "P2", "P3", "P4"]


def test_an_out_of_tolerance_dimension_predicted_out_is_marked() -> None:
    r = view.DimensionRow(
        "D1",
        "D1",
        "",
        deviation=0.3,
        lower=-0.1,
        upper=0.1,
        predicted=0.2,
        margin_before=-0.2,
        margin_after=-0.1,
        flags_=("out_before", "out", "binding", "given_up", "rejected"),
    )
    assert r.flags == "✗▲●⚑⊘" and not r.in_before and not r.in_after
    guarded = view.DimensionRow("D2", "D2", "", 0.0, -0.1, 0.1, 0.095, 0.1, 0.005, ("guard",))
    assert guarded.flags == "✓◇"


def test_filter_and_sort(correction: CycleCorrection) -> None:
    rows = view.dimension_rows(correction)
    p2 = view.filter_rows(rows, "P2")
    assert len(p2) == 7 and {r.station for r in p2} == {"P2"}
    assert view.filter_rows(rows, None) == rows
    by_margin = view.sort_rows(rows, "margin_after")
    assert [r.margin_after for r in by_margin] == sorted(r.margin_after for r in rows)
    assert view.sort_rows(rows, "name", reverse=True)[0].name == "P4 D7"


def test_register_rows_list_every_register_with_new_values_when_current_known(correction: CycleCorrection) -> None:
    rows = view.register_rows(correction, {"G58": 1.5, "T23": -2.0})
    assert [r.register for r in rows][:2] == ["G54", "G55"] and len(rows) == 10
    g58 = next(r for r in rows if r.register == "G58")
    assert g58.delta == pytest.approx(0.014) and g58.new == pytest.approx(1.514)
    assert next(r for r in rows if r.id == "T23").new == pytest.approx(-2.0 + 0.027)
    assert next(r for r in rows if r.id == "W1").new is None
    assert not any(r.at_limit for r in rows) and {r.offset for r in rows} == {"geometry", "wear"}


def test_register_rows_show_what_the_export_writes_feed_forward_included(correction: CycleCorrection) -> None:
    import dataclasses

    from setupfix.usecases.export import cycle_rows
    from setupfix.usecases.thermal_feedforward import ThermalFeedForward

    feed = ThermalFeedForward(
        "grey",
        4.2,
        "um",
        -0.004,
        "mm",
        ("T5", "T23"),
        ("H5", "H23"),
        "2026-11-02T08:00:00",
        "2026-11-02T09:00:00",
        0.001,
    )
    fed = dataclasses.replace(correction, thermal=feed)
    rows = view.register_rows(fed, {"H5": 0.5})
    written = {r.id: r.delta for r in cycle_rows(fed)}
    assert {r.id: r.delta for r in rows if not r.fixed} == pytest.approx(written)
    t5 = next(r for r in rows if r.id == "T5")
    assert t5.delta == pytest.approx(correction.corrections["T5"] - 0.004) and "thermal" in t5.rules
    assert t5.new == pytest.approx(0.5 + t5.delta)


def test_summary_is_the_headline_of_the_result(correction: CycleCorrection) -> None:
    s = view.summary(correction)
    assert (s.margin_before, s.margin_after) == (correction.margin_before, correction.margin_after)
    assert s.bonus == pytest.approx(0.0651) and s.verdict == "apply" and s.rules == () and s.alarm == ""
    assert s.unit == "mm" and s.in_tolerance


def test_a_gross_error_is_rejected_and_its_rules_and_flags_shown(tmp_path: Path) -> None:
    gross = tmp_path / "gross.csv"
    gross.write_text(
        (GUIDE_PINS / "cycle_01.csv")
        .read_text(encoding="utf-8")
        .replace("P1 D1,25.0000,24.9691,-0.0309", "P1 D1,25.0000,24.5000,-0.5000"),
        encoding="utf-8",
    )
    c = correct_report(REQUEST, gross).cycles[0]
    s = view.summary(c)
    assert s.verdict == "reject" and s.alarm and any(r.startswith("reject") for r in s.rules)
    p1d1 = next(r for r in view.dimension_rows(c) if r.name == "P1 D1")
    assert view.REJECTED in p1d1.flags and view.OUT in p1d1.flags
    assert all(r.delta == 0 for r in view.register_rows(c))


def test_match_rows_suggest_close_dimension_names(guide_pins_model: ProcessModel) -> None:
    table = pd.DataFrame({"characteristic": ["p1  d1", "Pin1 D2", "xyz"], "part": ["c", "c", None]})
    rows = view.match_rows(guide_pins_model, table)
    assert rows[0].matched and rows[0].dimension == next(d.id for d in guide_pins_model.dimensions if d.name == "P1 D1")
    assert not rows[1].matched and rows[1].suggestions[0] == "P1 D2"
    assert rows[2].suggestions == () and rows[2].part == ""


def test_convergence_is_the_median_best_so_far_and_ends_at_the_final_results(correction: CycleCorrection) -> None:
    comp = compare_problem(correction.problem, methods=("pso", "ga"), trials=3, seed=1)
    curves = analysis_view.convergence(comp, 20)
    for m in comp.methods:
        curve = curves[m.optimizer]
        assert curve.shape == (20,) and np.all(np.diff(curve) >= -1e-12)  # best-so-far never falls
        assert curve[-1] == pytest.approx(np.median(m.f1))
    assert [r["optimizer"] for r in analysis_view.compare_rows(comp)] == ["exact", "pso", "ga"]


def test_signed_and_limits_text() -> None:
    assert view.signed(-0.0) == "+0.0000" and view.signed(None) == "—" and view.signed(math.inf) == "—"
    assert view.limits_text(-0.1, 0.1) == "±0.100"
    assert view.limits_text(-0.05, 0.1) == "-0.050/+0.100"
