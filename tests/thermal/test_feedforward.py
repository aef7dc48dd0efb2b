"""Drift fed forward: the change since the measured parts were cut, its sign, units and dead band."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from parsers.temperature import read_temperature_log
from setupfix.core.errors import ParameterError, ParseError
from setupfix.inputs.thermal_files import load_model
from setupfix.model import load_model as load_process_model
from setupfix.thermal import prediction as pipe
from setupfix.thermal.feedforward import drift_change, feed_forward, sample_at_or_before
from setupfix.thermal.persist import SavedModel
from setupfix.usecases import thermal_fit
from setupfix.usecases.thermal_feedforward import thermal_feed_forward

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_reports" / "thermal"
GUIDE_PINS = ROOT / "sample_reports" / "guide_pins" / "model.toml"


def test_join_at_or_before_and_change_since_measured() -> None:
    times = np.array([0.0, 10.0, 20.0, 30.0])
    drift = np.array([0.0, 1.0, 3.0, 6.0])
    np.testing.assert_array_equal(sample_at_or_before(times, [-1, 0, 9.9, 10, 35]), [-1, 0, 0, 1, 3])
    assert drift_change(drift, times, 15.0) == 5.0  # joined to 10 s (1.0), latest 6.0
    assert drift_change(drift, times, 15.0, at=29.0) == 2.0
    np.testing.assert_array_equal(drift_change(drift, times, [0.0, 20.0]), [6.0, 3.0])  # several parts at once
    with pytest.raises(ValueError, match="before the first"):
        drift_change(drift, times, -5.0)
    with pytest.raises(ValueError, match="after the time of the correction"):
        drift_change(drift, times, 25.0, at=12.0)


def test_feed_forward_sign_grid_and_dead_band() -> None:
    moves = np.array([False, True, True])
    np.testing.assert_allclose(feed_forward(4.2, moves, factor=1e-3, resolution=0.001), [0, -0.004, -0.004])
    np.testing.assert_allclose(feed_forward(-2.6, moves, factor=1e-3, resolution=0.001), [0, 0.003, 0.003])
    assert not feed_forward(0.9, moves, factor=1e-3, resolution=0.001, dead_band=0.001).any()
    assert feed_forward(1.0, moves, factor=1e-3, resolution=0.001, dead_band=0.001).any()


@pytest.fixture(scope="module")
def fitted() -> SavedModel:
    log = read_temperature_log(SAMPLES / "train_variable.csv")
    return thermal_fit.fit_log(log, "mra", target="error_z", inputs=["spindle_motor", "bearing"], unit="mm").saved


def test_guide_pins_feed_forward_on_a_simulated_log(fitted: SavedModel) -> None:
    model = load_process_model(GUIDE_PINS)
    log = read_temperature_log(SAMPLES / "test_variable.csv")
    drift = pipe.predict_log(fitted, log)[0]
    measured_at, at = log.timestamps[100], log.timestamps[700]
    ff = thermal_feed_forward(model, fitted, log, measured_at=measured_at, at=at)
    delta = drift[700] - drift[100]
    assert abs(delta) > 0.005 and ff.delta == pytest.approx(delta)
    assert ff.registers == ("T5", "T23") and ff.names == ("H5", "H23")  # spindle growth: every tool
    assert ff.shift == pytest.approx(-np.round(delta / 0.001) * 0.001)  # cancels the change, on the grid
    assert np.sign(ff.shift) == -np.sign(delta)
    assert ff.line().startswith(f"thermal feed-forward {ff.shift:+.4g} mm on H5, H23")
    quiet = thermal_feed_forward(model, fitted, log, measured_at=measured_at, at=at, dead_band=1.0)
    assert not quiet.applied and quiet.corrections() == {} and "dead band" in quiet.line()
    later = thermal_feed_forward(model, fitted, log, measured_at=measured_at)  # default: the latest sample
    assert later.delta == pytest.approx(drift[-1] - drift[100])


def test_unit_conversion_and_refusals(fitted: SavedModel) -> None:
    model = load_process_model(GUIDE_PINS)
    log = read_temperature_log(SAMPLES / "test_variable.csv")
    in_um = thermal_fit.fit_log(
        read_temperature_log(SAMPLES / "train_variable.csv").slice(0, 1440),
        "mra",
        target="error_z",
        inputs=["spindle_motor", "bearing"],
        unit="um",
    ).saved
    mm = thermal_feed_forward(model, fitted, log, measured_at=log.timestamps[100], dead_band=0.0)
    um = thermal_feed_forward(model, in_um, log, measured_at=log.timestamps[100], dead_band=0.0)
    assert um.delta == pytest.approx(mm.delta)  # the same numbers, read as µm…
    assert um.shift == pytest.approx(-np.round(mm.delta * 1e-3 / 0.001) * 0.001)  # …move a thousandth as much
    in_um.unit = None
    with pytest.raises(ParseError, match="does not state the unit"):
        thermal_feed_forward(model, in_um, log, measured_at=log.timestamps[100])
    with pytest.raises(ParameterError, match="before the first"):
        thermal_feed_forward(model, fitted, log, measured_at="2026-01-01T00:00:00")
    with pytest.raises(ParameterError, match="report gives no timestamp"):
        thermal_feed_forward(model, fitted, log, measured_at=None)
    fitted_x = thermal_fit.fit_log(
        read_temperature_log(SAMPLES / "train_variable.csv"), "mra", target="error_z", unit="mm", axis="X"
    ).saved
    with pytest.raises(ParameterError, match="acts along X"):
        thermal_feed_forward(model, fitted_x, log, measured_at=log.timestamps[100])


@pytest.mark.slow
def test_correct_with_thermal_feed_forward(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``setupfix correct --thermal --temperatures``: the guide-pins cycle cut at 08:00, corrected at 09:00."""
    import json

    import setupfix.cli as cli

    monkeypatch.setattr(cli, "COMMAND_MODULES", ("setupfix.cli.correct", "setupfix.cli.thermal"))
    log = tmp_path / "temps.csv"
    log.write_text((SAMPLES / "test_variable.csv").read_text().replace("2026-01-05T", "2026-11-02T"))
    model = tmp_path / "drift.json"
    assert (
        cli.main(
            [
                "thermal",
                "fit",
                "--method",
                "mra",
                str(SAMPLES / "train_variable.csv"),
                "--target",
                "error_z",
                "--inputs",
                "spindle_motor,bearing",
                "--unit",
                "mm",
                "-o",
                str(model),
            ]
        )
        == 0
    )
    report = str(ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv")
    base = ["correct", "--model", str(GUIDE_PINS), report, "--json"]
    capsys.readouterr()
    assert cli.main(base) == 0
    plain = json.loads(capsys.readouterr().out)
    assert cli.main([*base, "--thermal", str(model), "--temperatures", str(log), "--at", "2026-11-02T09:00:00"]) == 0
    fed = json.loads(capsys.readouterr().out)
    th = fed["thermal"]
    drift = pipe.predict_log(load_model(model), read_temperature_log(log))[0]
    assert th["delta"] == pytest.approx(drift[1080] - drift[720])  # 09:00 and 08:00, sampled every 10 s from 06:00
    assert th["applied"] and th["registers"] == ["T5", "T23"] and th["shift"] == pytest.approx(-round(th["delta"], 3))
    for reg in ("T5", "T23"):
        assert fed["corrections"][reg] == pytest.approx(plain["corrections"][reg] + th["shift"])
    assert fed["corrections"]["W1"] == plain["corrections"]["W1"]
    assert (
        cli.main([*base[:-1], "--thermal", str(model), "--temperatures", str(log), "--at", "2026-11-02T09:00:00"]) == 0
    )
    assert "thermal feed-forward" in capsys.readouterr().out
    assert cli.main([*base, "--thermal", str(model)]) == 1
    assert "go together" in capsys.readouterr().err
