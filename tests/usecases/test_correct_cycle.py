"""The correct use case as every door uses it: compare, the diagnosis's next correction, the history."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import GUIDE_PINS, SAMPLES
from usecases.data import make_correct_goldens as golden

from setupfix.diagnose import Diagnoser
from setupfix.inputs.cycles import load_parts
from setupfix.model import PartMeasurement, ProcessModel, load_model
from setupfix.store import open_store
from setupfix.usecases.compare import CompareRequest, compare_report
from setupfix.usecases.correct import correct_cycle, correct_report
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports, forecast_model
from setupfix.usecases.requests import CorrectRequest, History, SolveOptions

CYCLES = [GUIDE_PINS / f"cycle_{k:02d}.csv" for k in range(1, 6)]


@pytest.fixture(scope="module")
def costed(tmp_path_factory: pytest.TempPathFactory) -> ProcessModel:
    """The guide-pins model with register costs, gain, guard band and dead band (the goldens' model)."""
    return load_model(golden.costed_model(tmp_path_factory.mktemp("costed")))


@pytest.mark.parametrize("report", CYCLES, ids=lambda p: p.stem)
def test_compare_exact_is_corrects_raw_optimum_with_costs(costed: ProcessModel, report: Path) -> None:
    # compare's yardstick is the paper's objective (issue 22): correct asked for the same
    cycle = correct_report(CorrectRequest(costed, solve=SolveOptions(objective="paper")), report).cycles[0]
    comparison = compare_report(CompareRequest(costed, methods=(), trials=1), report)
    raw = cycle.recommendation.result
    np.testing.assert_array_equal(comparison.exact.x, raw.x)
    assert comparison.exact.margin_after == raw.margin_after and comparison.exact.fitness == raw.fitness
    np.testing.assert_array_equal(comparison.problem.cost, [r.cost for r in costed.registers])
    assert comparison.problem.cost.max() == 4.0


def test_diagnosis_next_correction_is_correct_on_its_forecast() -> None:
    loop = SAMPLES / "closed_loop"
    out = diagnose_reports(
        DiagnoseRequest(
            GUIDE_PINS / "model.toml",
            (loop / "measurements.csv",),
            corrections=str(loop / "corrections.csv"),
            temperatures=str(loop / "temperatures.csv"),
            diagnoser=Diagnoser(walk=False),
        )
    )
    fc = out.diagnosis.forecast
    part = PartMeasurement(part="next", report="forecast", timestamp=None, deviation=fc, sources=tuple("" for _ in fc))
    model = forecast_model(out.input.model)
    again = correct_cycle(CorrectRequest(model), part, composite=out.diagnosis.relation_matrix())
    assert out.next_cycle is not None and out.next_correction == again.corrections
    np.testing.assert_array_equal(out.next_cycle.x, again.x)
    assert out.next_cycle.verdict == again.verdict
    np.testing.assert_array_equal(again.problem.composite, out.diagnosis.relation_matrix()[:, part.measured])


def test_store_history_equals_the_parts_given_and_counts_a_part_once(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE_PINS / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    model = load_model(path)
    db = tmp_path / "h.db"
    code, _, err = golden.run(["history", "import", "--db", db, "--model", path, *CYCLES])
    assert code == 0, err
    with open_store(db) as store:
        stored = History.from_store(model, store)
    parts = [p for r in CYCLES for p in load_parts(model, r)]
    given = History.empty(model).with_parts(parts)
    assert stored.with_parts(parts).keys == stored.keys  # the same parts are not counted twice
    for report in CYCLES:
        a = correct_report(CorrectRequest(model, history=stored), report).cycles[0]
        b = correct_report(CorrectRequest(model, history=given), report).cycles[0]
        assert a.corrections == b.corrections and a.verdict == b.verdict
        np.testing.assert_array_equal(a.problem.deviation, b.problem.deviation)
    last = correct_report(CorrectRequest(model, history=given), CYCLES[-1]).cycles[0]
    rule = last.recommendation.rules[0]
    assert rule.rule == "ewma" and "over 4 earlier part(s)" in rule.message
    plain = correct_report(CorrectRequest(model), CYCLES[-1]).cycles[0]
    assert any("needs the history store" in n.message for n in plain.notes)


def test_outcome_reads_once_and_states_what_it_read() -> None:
    import hashlib

    import parsers

    source = parsers.load_source(GUIDE_PINS / "cycle_01.csv")
    out = correct_report(CorrectRequest(load_model(GUIDE_PINS / "model.toml")), source)
    assert out.sha256 == hashlib.sha256(source.data).hexdigest() and out.format and len(out.table)
    assert out.report == source.name and len(out.cycles) == 1 and not out.rejected


def test_thermal_feed_forward_is_a_step_of_the_use_case_and_requests_pickle(tmp_path: Path) -> None:
    """The feed-forward joins the corrections (not a CLI step); the whole request survives pickling
    (batch sends it to its workers) and gives the same answer there."""
    import pickle

    from parsers.temperature import read_temperature_log
    from setupfix.usecases import thermal_fit
    from setupfix.usecases.requests import ThermalInputs

    thermal = SAMPLES / "thermal"
    saved = thermal_fit.fit_log(
        read_temperature_log(thermal / "train_variable.csv"),
        "mra",
        target="error_z",
        inputs=["spindle_motor", "bearing"],
        unit="mm",
    ).saved
    log_path = tmp_path / "temps.csv"
    log_path.write_text((thermal / "test_variable.csv").read_text().replace("2026-01-05T", "2026-11-02T"))
    log = read_temperature_log(log_path, interval=saved.sample_interval_s)
    model = load_model(GUIDE_PINS / "model.toml")
    request = CorrectRequest(model, thermal=ThermalInputs(saved, log, "drift.json", at="2026-11-02T09:00:00"))
    fed = correct_report(request, CYCLES[0]).cycles[0]
    plain = correct_report(CorrectRequest(model), CYCLES[0]).cycles[0]
    ff = fed.thermal
    assert ff is not None and ff.applied and ff.registers == ("T5", "T23")
    for reg in model.register_ids:
        assert fed.corrections[reg] == pytest.approx(plain.corrections[reg] + ff.corrections().get(reg, 0.0))
    np.testing.assert_array_equal(fed.x, plain.x)  # the setup correction itself is unchanged
    again = correct_report(pickle.loads(pickle.dumps(request)), CYCLES[0]).cycles[0]
    assert again.corrections == fed.corrections
    from setupfix.views.present import format_correction

    text = format_correction(fed)
    assert ff.line() in text and text.index(ff.line()) < text.index("error budget before")


def test_load_request_reads_each_input_once_and_only_what_the_model_uses(tmp_path: Path) -> None:
    from setupfix.core.errors import SetupfixError
    from setupfix.usecases.correct import load_request

    controllers = SAMPLES / "controllers"
    req = load_request(controllers / "model.toml", current=controllers / "current.csv")
    assert req.current is not None and req.current.source.endswith("current.csv") and req.history is None
    assert req.current.wear_totals(req.model) == {"T5": req.current["T5"], "T12": req.current["T12"]}
    smooth = tmp_path / "m.toml"
    smooth.write_text((GUIDE_PINS / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    db = tmp_path / "h.db"
    assert golden.run(["history", "import", "--db", db, "--model", smooth, *CYCLES])[0] == 0
    assert load_request(smooth, store=db).history is not None
    # λ = 1: nothing to smooth, but the store's parts stand in for dimensions a report lacks (issue 22, coverage)
    assert load_request(GUIDE_PINS / "model.toml", store=db).history is not None
    with pytest.raises(SetupfixError, match="go together"):
        load_request(GUIDE_PINS / "model.toml", thermal=tmp_path / "t.json")
    with pytest.raises(SetupfixError, match="no history store"):
        load_request(GUIDE_PINS / "model.toml", store=tmp_path / "none.db")
