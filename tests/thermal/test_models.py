"""Estimator classes: MRA closed form, Grey b1 > 0, fusion recovery and robustness, JSON round trip."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.core.errors import NotFittedError, ParseError
from setupfix.inputs.thermal_files import load_model, save_model
from setupfix.thermal.estimator import Array, MRAModel
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.metrics import efficiency, max_residual, rmse, rmsv, score
from setupfix.thermal.persist import SavedModel
from setupfix.thermal.simulator import SimulatedRun, add_sensor_error, fail_sensor, sinusoidal_error

SENSORS = ["spindle_motor", "bearing"]
SimRuns = tuple[SimulatedRun, SimulatedRun]  # the sim_runs fixture: training and test
Fitted = tuple[KalmanFusionModel, MRAModel]  # the fitted fixture


def arrays(frame: pd.DataFrame) -> tuple[Array, Array, Array, Array]:
    return (
        frame[SENSORS].to_numpy(),
        frame["error_z"].to_numpy(),
        frame["ambient"].to_numpy(),
        frame["spindle_speed"].to_numpy(),
    )


def test_metrics_by_hand() -> None:
    e, p = np.array([1.0, 2.0, 3.0]), np.array([1.0, 3.0, 2.0])
    assert rmse(e, p) == pytest.approx(np.sqrt(2 / 3))
    assert rmsv(e, p) == pytest.approx(1.0)
    assert max_residual(e, p) == 1.0
    assert efficiency(e, p) == pytest.approx(0.0)  # Σr² = 2 = Σ(e-ē)²
    s = score([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 3.0, 2.0])
    assert s.n == 3 and s.rmse == pytest.approx(np.sqrt(2 / 3))


def test_mra_recovers_exact_coefficients() -> None:
    rng = np.random.default_rng(0)
    T = 20 + np.cumsum(rng.random((40, 2)), axis=0)
    y = (T - T[0]) @ [0.004, -0.002]
    m = MRAModel().fit(T, y)
    np.testing.assert_allclose(m.beta_, [0.004, -0.002], atol=1e-12)
    np.testing.assert_allclose(m.predict(T[20:]), y[20:], atol=1e-12)  # a log starting warm: as if continuous
    np.testing.assert_allclose(m.predict(T + 5.0, y0=y[0]), y, atol=1e-12)  # re-based on a measured error


def test_predict_before_fit_raises() -> None:
    with pytest.raises(NotFittedError):
        MRAModel().predict(np.zeros((3, 1)))


def test_grey_ls_keeps_development_coefficient_positive() -> None:
    k = np.arange(20.0)
    y = 2.0 ** (k / 4) - 1  # growing series: unconstrained LS gives b1 < 0
    X = np.column_stack([k, np.ones(20)])
    from setupfix.thermal.grey import gmc_least_squares

    assert gmc_least_squares(y, X)[0] < 0
    m = GreyModel(calibration="ls").fit(X, y)
    assert m.theta_[0] >= 1e-6
    assert np.all(np.isfinite(m.predict(np.vstack([X, X]), y0=0.0)))


@pytest.mark.slow
def test_grey_cs_fits_its_own_model() -> None:
    rng = np.random.default_rng(1)
    X = np.cumsum(rng.normal(0.5, 0.3, (80, 2)), axis=0)
    from setupfix.thermal.grey import gmc_predict

    truth = np.array([0.3, 0.8, -0.4, 1.5])
    y = gmc_predict(truth, 0.0, X - X[0])
    m = GreyModel(calibration="cs", bound=5.0, iterations=1000, seed=0).fit(X, y)
    assert m.train_rmse_ < 1e-3 * np.ptp(y)
    np.testing.assert_allclose(m.theta_, truth, rtol=1e-3)


@pytest.mark.slow
def test_kalman_fusion_recovers_lumped_parameters(fitted: Fitted, sim_runs: SimRuns) -> None:
    train, _ = sim_runs
    T, y, te, sp = arrays(train.frame)
    m = fitted[0]
    motor = train.config.sources[0]
    v1, v2 = motor.coefficients(train.config.dt_s)  # the motor follows eq. (4) exactly
    assert m.v_[0, 0] == pytest.approx(v1, rel=0.15)
    assert m.v_[0, 1] / m.v_[0, 0] == pytest.approx(v2 / v1, rel=0.05)
    assert m.A_[0] == pytest.approx(1 / (1 + v1), abs=2e-3)
    assert score(y, m.predict(T, ambient=te, speed=sp)).efficiency > 0.95


@pytest.fixture(scope="module")
def fitted(sim_runs: SimRuns) -> Fitted:
    train, _ = sim_runs
    T, y, te, sp = arrays(train.frame)
    return (KalmanFusionModel(seed=0, generations=20).fit(T, y, ambient=te, speed=sp), MRAModel().fit(T, y))


@pytest.mark.slow
def test_robustness_to_sinusoidal_sensor_error(fitted: Fitted, sim_runs: SimRuns) -> None:
    """Wang (2017) §4: eq. (18) on the motor sensor raises the fused model's RMSV less than MRA's."""
    kf, mra = fitted
    _, test = sim_runs
    clean = arrays(test.frame)
    noisy = arrays(add_sensor_error(test.frame, "spindle_motor", sinusoidal_error))
    rms = {}
    for name, (T, y, te, sp) in (("clean", clean), ("sin", noisy)):
        rms[name] = (score(y, kf.predict(T, ambient=te, speed=sp)).rmsv, score(y, mra.predict(T)).rmsv)
    growth_kf = rms["sin"][0] - rms["clean"][0]
    growth_mra = rms["sin"][1] - rms["clean"][1]
    assert growth_kf < 0.5 * growth_mra


def test_prediction_with_failed_sensors(fitted: Fitted, sim_runs: SimRuns) -> None:
    kf, _ = fitted
    _, test = sim_runs
    T, y, te, sp = arrays(test.frame)
    blind = kf.predict(T, ambient=te, speed=sp, sensors_failed=True)
    assert score(y, blind).efficiency > 0.8  # most of the drift from the lumped-mass model alone
    broken = fail_sensor(test.frame, "bearing", 200, value=-200.0)  # open circuit: a jump
    Tb, *_ = arrays(broken)
    pred = kf.predict(Tb, ambient=te, speed=sp)
    assert np.all(np.isfinite(pred)) and score(y, pred).efficiency > 0.8


@pytest.mark.slow
def test_streaming_prediction_matches_batch(fitted: Fitted, sim_runs: SimRuns) -> None:
    kf, _ = fitted
    _, test = sim_runs
    T, y, te, sp = arrays(test.frame)
    stream = kf.stream()
    online = [stream.step(T[j], te[j], sp[j]) for j in range(len(y))]
    np.testing.assert_allclose(online, kf.predict(T, ambient=te, speed=sp), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("kind", ["mra", "grey", "kalman"])
def test_json_round_trip(kind: str, fitted: Fitted, sim_runs: SimRuns, tmp_path: Path) -> None:
    _, test = sim_runs
    T, y, te, sp = arrays(test.frame)
    model = {
        "mra": fitted[1],
        "kalman": fitted[0],
        "grey": GreyModel(calibration="pso", iterations=5, seed=3).fit(T, y),
    }[kind]
    path = tmp_path / "m.json"
    save_model(SavedModel(model, tuple(SENSORS), "error_z", "ambient", "spindle_speed", 10.0), path)
    back = load_model(path)
    ambient, speed = (te, sp) if kind == "kalman" else (None, None)
    np.testing.assert_allclose(
        back.model.predict(T, ambient=ambient, speed=speed), model.predict(T, ambient=ambient, speed=speed), rtol=1e-12
    )
    assert back.inputs == tuple(SENSORS) and back.sample_interval_s == 10.0
    doc = json.loads(path.read_text())
    doc["version"] = 99
    path.write_text(json.dumps(doc))
    with pytest.raises(ParseError, match="version"):
        load_model(path)
