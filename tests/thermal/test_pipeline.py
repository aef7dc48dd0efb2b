"""Use cases: fit a log, save, and predict drift from the saved model (what the TUI calls)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from setupfix.errors import ParseError, ParseWarning
from setupfix.pipeline import thermal as pipe
from setupfix.thermal.data import TemperatureLog, read_temperature_log
from setupfix.thermal.metrics import score

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "thermal"


def test_fit_save_and_predict_drift(tmp_path):
    out = tmp_path / "mra.json"
    saved = pipe.fit_file(SAMPLES / "train_variable.csv", "mra", target="error_z", out=out,
                          inputs=["spindle_motor", "bearing"])
    assert saved.train["n"] == 1439 and saved.sample_interval_s == 10.0
    drift = pipe.predict_drift(out, SAMPLES / "test_constant.csv")
    assert drift.drift.shape == (1440,) and drift.timestamps[0] == "2026-01-05T06:00:00"
    assert drift.latest == pytest.approx(drift.drift[-1])
    assert score(drift.measured, drift.drift).rmse < 0.015  # mm; MRA generalises poorly to constant speed


def test_kalman_needs_speed_and_mra_refuses_gaps():
    log = read_temperature_log(SAMPLES / "train_variable.csv")
    cols = {k: v for k, v in log.columns.items() if k != "spindle_speed"}
    with pytest.raises(ParseError, match="spindle speed"):
        pipe.fit_log(TemperatureLog.from_arrays("x.csv", cols), "kalman", target="error_z")
    gappy = dict(log.columns)
    gappy["bearing"] = gappy["bearing"].copy()
    gappy["bearing"][5] = np.nan
    with pytest.raises(ParseError, match="x.csv:7: empty value in column 'bearing'"):
        pipe.fit_log(TemperatureLog.from_arrays("x.csv", gappy), "mra", target="error_z")


def test_other_sampling_interval_warns():
    log = read_temperature_log(SAMPLES / "train_variable.csv")
    saved = pipe.fit_log(log, "grey-ls", target="error_z")
    other = TemperatureLog.from_arrays("y.csv", log.columns, seconds=np.arange(log.n) * 60.0)
    with pytest.warns(ParseWarning, match="fitted on 10 s"):
        pipe.predict_log(saved, other)


def test_unknown_method():
    with pytest.raises(ParseError, match="unknown thermal method"):
        pipe.make_model("neural")


def test_kalman_predicts_through_a_missing_reading_but_does_not_fit_on_one():
    log = read_temperature_log(SAMPLES / "train_variable.csv")
    short = TemperatureLog.from_arrays("s.csv", {k: v[:600] for k, v in log.columns.items()})
    saved = pipe.fit_log(short, "kalman", target="error_z", seed=0)
    gappy = {k: v[:600].copy() for k, v in log.columns.items()}
    gappy["bearing"][300] = np.nan
    pred = pipe.predict_log(saved, TemperatureLog.from_arrays("g.csv", gappy))
    assert np.all(np.isfinite(pred))
    with pytest.raises(ParseError, match="g.csv:302: empty value in column 'bearing'"):
        pipe.fit_log(TemperatureLog.from_arrays("g.csv", gappy), "kalman", target="error_z")


def test_non_finite_model_is_not_saved(tmp_path):
    from setupfix.errors import ExportError
    from setupfix.thermal.models import MRAModel
    from setupfix.thermal.persist import SavedModel, save_model

    model = MRAModel()
    model.beta_ = np.array([np.nan])
    with pytest.raises(ExportError, match="non-finite"):
        save_model(SavedModel(model, ("T",), "E"), tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()
