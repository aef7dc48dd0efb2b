"""Use cases: fit a log, save, and predict drift from the saved model (what the TUI calls)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.core.errors import ExportError, ParameterError, ParseError
from setupfix.inputs.thermal_files import load_model, predict_drift, save_model
from setupfix.thermal import prediction as pipe
from setupfix.thermal.estimator import MRAModel
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.metrics import score
from setupfix.thermal.persist import SavedModel
from setupfix.thermal.registry import get_method, make_model, methods
from setupfix.usecases import thermal_fit

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "thermal"
SENSORS = ["spindle_motor", "bearing"]


@pytest.fixture(scope="module")
def train_log() -> TemperatureLog:
    return read_temperature_log(SAMPLES / "train_variable.csv")


def test_fit_save_and_predict_drift(tmp_path: Path) -> None:
    out = tmp_path / "mra.json"
    saved = thermal_fit.fit_file(
        SAMPLES / "train_variable.csv", "mra", target="error_z", out=out, inputs=SENSORS, unit="mm"
    ).saved
    assert saved.train["n"] == 1439 and saved.sample_interval_s == 10.0
    drift = predict_drift(out, SAMPLES / "test_constant.csv")
    assert drift.drift.shape == (1440,) and drift.timestamps[0] == "2026-01-05T06:00:00" and drift.unit == "mm"
    assert drift.measured is not None
    assert score(drift.measured, drift.drift).rmse < 0.015  # mm; MRA generalises poorly to constant speed


def test_reference_state_saved_and_reloaded(tmp_path: Path, train_log: TemperatureLog) -> None:
    saved = thermal_fit.fit_log(train_log, "grey-ls", target="error_z", inputs=SENSORS, unit="um").saved
    np.testing.assert_array_equal(saved.model.T_ref_, [train_log.columns[c][0] for c in SENSORS])
    save_model(saved, tmp_path / "g.json")
    back = load_model(tmp_path / "g.json")
    np.testing.assert_array_equal(back.model.T_ref_, saved.model.T_ref_)
    assert back.model.y_ref_ == saved.model.y_ref_ and back.unit == "um"
    warm = train_log.slice(700, 1440)
    np.testing.assert_allclose(pipe.predict_log(back, warm)[0], pipe.predict_log(saved, warm)[0], rtol=1e-12)


@pytest.mark.parametrize("method", ["mra", "grey-ls", "kalman"])
def test_log_starting_warm_is_predicted_as_if_continuous(train_log: TemperatureLog, method: str) -> None:
    """The second half of a log, read on its own, gets the prediction the whole log gives it."""
    short = train_log.head(720)
    saved = thermal_fit.fit_log(
        short,
        method,
        target="error_z",
        inputs=SENSORS,
        params={"generations": 5, "pop_size": 8} if method == "kalman" else None,
    ).saved
    whole = pipe.predict_log(saved, train_log)[0]
    warm = pipe.predict_log(saved, train_log.slice(720, 1440))[0]
    y = train_log.columns["error_z"][720:]
    assert abs(y[0]) > 0.02  # mm: the machine is warm there
    if method == "mra":
        np.testing.assert_allclose(warm, whole[720:], atol=1e-12)
    else:  # dynamic models restart from the measured temperatures: a short transient only
        np.testing.assert_allclose(warm[60:], whole[780:], atol=2e-3)
    assert score(y, warm).rmse < 0.01  # the old rises-from-the-log's-start prediction was off by the whole drift


def test_anchor_rebases_on_a_measured_error(train_log: TemperatureLog) -> None:
    saved = thermal_fit.fit_log(train_log, "mra", target="error_z", inputs=SENSORS).saved
    plain = pipe.predict_log(saved, train_log)[0]
    anchored = pipe.predict_log(saved, train_log, anchor=pipe.parse_anchor("2026-01-05T07:00:05=0.5"))[0]
    i = 360  # 07:00:00 is the last sample at or before 07:00:05
    assert anchored[i] == pytest.approx(0.5)
    np.testing.assert_allclose(anchored - plain, 0.5 - plain[i])
    first = pipe.predict_log(saved, train_log, anchor=pipe.parse_anchor("first"))[0]
    assert first[0] == pytest.approx(train_log.columns["error_z"][0])
    for bad in ("07:00", "2026-01-05T07:00=x", "=1"):
        with pytest.raises(ParameterError):
            pipe.predict_log(saved, train_log, anchor=pipe.parse_anchor(bad))
    with pytest.raises(ParameterError, match="outside the log"):
        pipe.predict_log(saved, train_log, anchor=pipe.parse_anchor("2020-01-01T00:00:00=0"))


def test_kalman_without_speed_falls_back_and_is_flagged(train_log: TemperatureLog) -> None:
    cols: dict[str, npt.ArrayLike] = {
        k: v[:300] for k, v in train_log.columns.items() if k not in ("spindle_speed", "ambient")
    }
    log = TemperatureLog.from_arrays("x.csv", cols)
    result = thermal_fit.fit_log(log, "kalman", target="error_z", params={"generations": 5, "pop_size": 8})
    assert isinstance(result.saved.model, KalmanFusionModel)
    assert result.saved.speed is None and not result.saved.model.uses_speed_
    assert {n.kind for n in result.notes} >= {"fallback"}
    assert any("without a spindle speed" in str(n) for n in result.notes)
    with pytest.raises(ParameterError, match="sensors_failed"):
        pipe.predict_log(result.saved, log, sensors_failed=True)
    with pytest.raises(ParameterError, match="kalman"):
        pipe.predict_log(thermal_fit.fit_log(log, "mra", target="error_z").saved, log, sensors_failed=True)


def test_mra_refuses_gaps_and_implausible_values(train_log: TemperatureLog) -> None:
    bearing = train_log.columns["bearing"].copy()
    bearing[5] = np.nan
    gappy: dict[str, npt.ArrayLike] = {**train_log.columns, "bearing": bearing}
    with pytest.raises(ParseError, match=r"x.csv:7: empty value in column 'bearing'"):
        thermal_fit.fit_log(TemperatureLog.from_arrays("x.csv", gappy), "mra", target="error_z")
    for value, what in ((1e300, "temperature"), (1e306, "temperature")):
        bearing = train_log.columns["bearing"].copy()
        bearing[9] = value
        hot: dict[str, npt.ArrayLike] = {**train_log.columns, "bearing": bearing}
        with pytest.raises(ParseError, match=rf"x.csv:11: {what} 1e\+30\d in column 'bearing' is outside"):
            thermal_fit.fit_log(TemperatureLog.from_arrays("x.csv", hot), "grey-ls", target="error_z")


def test_bad_roles_and_constant_target(train_log: TemperatureLog) -> None:
    with pytest.raises(ParameterError, match="both the target and a temperature input"):
        thermal_fit.fit_log(train_log, "mra", target="error_z", inputs=["error_z"])
    const: dict[str, npt.ArrayLike] = dict(train_log.columns)
    const["error_z"] = np.full(train_log.n, 0.25)
    with pytest.raises(ParseError, match="constant"):
        thermal_fit.fit_log(TemperatureLog.from_arrays("c.csv", const), "mra", target="error_z")


def test_other_sampling_interval_is_noted(train_log: TemperatureLog) -> None:
    saved = thermal_fit.fit_log(train_log, "grey-ls", target="error_z").saved
    columns: dict[str, npt.ArrayLike] = dict(train_log.columns)
    other = TemperatureLog.from_arrays("y.csv", columns, seconds=np.arange(train_log.n) * 60.0)
    _, notes = pipe.predict_log(saved, other)
    assert any("fitted on 10 s" in str(n) for n in notes)


def test_quality_gate_and_default_seed(train_log: TemperatureLog) -> None:
    ev = thermal_fit.evaluate_logs(
        train_log.head(400), train_log.slice(400, 800), "grey-pso", target="error_z", params={"iterations": 3}
    )
    assert ev.saved.train["seed"] == 0
    assert ev.train.efficiency < 0 and any(n.kind == "quality" for n in ev.notes)
    assert any("training efficiency" in w for w in ev.as_json()["warnings"])
    again = thermal_fit.evaluate_logs(
        train_log.head(400), train_log.slice(400, 800), "grey-pso", target="error_z", params={"iterations": 3}
    )
    assert again.test.rmse == ev.test.rmse  # reproducible without --seed


def test_registry_validates_and_names_methods() -> None:
    assert methods() == ("mra", "grey-ls", "grey-cs", "grey-pso", "kalman")
    with pytest.raises(ParameterError, match=r"unknown thermal method 'neural'.*mra, grey-ls"):
        make_model("neural")
    with pytest.raises(ParameterError, match="iterations must be an int in"):
        make_model("grey-cs", iterations=-5)
    with pytest.raises(ParameterError, match="has no parameter colour"):
        make_model("mra", colour="red")
    for name in methods():  # every method: declared constraints cover every parameter
        model = make_model(name)
        assert set(model.get_params()) <= set(model._parameter_constraints), name


def test_non_finite_model_is_not_saved(tmp_path: Path) -> None:
    model = MRAModel()
    model.beta_ = np.array([np.nan])
    model.T_ref_, model.y_ref_ = np.zeros(1), 0.0
    with pytest.raises(ExportError, match="non-finite"):
        save_model(SavedModel(model, ("T",), "E"), tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()


@pytest.mark.parametrize("damage", ["byte", "coefficient", "reference", "method", "nan"])
def test_corrupt_model_file_is_named(tmp_path: Path, train_log: TemperatureLog, damage: str) -> None:
    path = tmp_path / "m.json"
    save_model(thermal_fit.fit_log(train_log, "mra", target="error_z", inputs=SENSORS).saved, path)
    text = path.read_text()
    if damage == "byte":
        path.write_bytes(text.encode()[:50] + b"\xff" + text.encode()[50:])
    else:
        doc = json.loads(text)
        if damage == "coefficient":
            doc["model"]["learned"]["beta_"].pop()
        elif damage == "reference":
            del doc["model"]["learned"]["T_ref_"]
        elif damage == "method":
            doc["model"]["method"] = "neural"
        path.write_text(json.dumps(doc).replace("0.0", "NaN", 1) if damage == "nan" else json.dumps(doc))
    with pytest.raises(ParseError, match=r"m\.json"):
        load_model(path)


SMALL = {"grey-cs": {"iterations": 5}, "grey-pso": {"iterations": 5}, "kalman": {"generations": 3, "pop_size": 6}}


@pytest.mark.parametrize("method", methods())
def test_every_method_is_deterministic_per_seed_and_refuses_bad_values(train_log: TemperatureLog, method: str) -> None:
    log = train_log.head(200)
    params = SMALL.get(method, {})
    first = pipe.predict_log(thermal_fit.fit_log(log, method, target="error_z", params=params).saved, log)[0]
    again = pipe.predict_log(thermal_fit.fit_log(log, method, target="error_z", params=params).saved, log)[0]
    np.testing.assert_array_equal(first, again)
    fixed = get_method(method).fixed
    for name, value in make_model(method).get_params().items():
        if name in fixed:  # fixed by the method's name
            continue
        bad = "nonsense" if not isinstance(value, str) else 12345
        with pytest.raises(ParameterError, match=name):
            make_model(method, **{name: bad})
    if fixed:
        with pytest.raises(ParameterError, match="fixes calibration"):
            make_model(method, calibration="ls")
