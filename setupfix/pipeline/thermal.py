"""Thermal-drift use cases: fit a model on a temperature log, evaluate it, predict drift.

Shared by ``setupfix thermal fit|predict|evaluate`` and (later) the operator TUI,
which shows :func:`predict_drift` beside the corrections.  Nothing here prints.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.errors import ParseError, ParseWarning, SourceLocation
from setupfix.thermal.data import Selection, TemperatureLog, read_temperature_log, select_columns
from setupfix.thermal.metrics import Scores, score
from setupfix.thermal.models import AnyThermalModel, GreyModel, KalmanFusionModel, MRAModel
from setupfix.thermal.persist import SavedModel, load_model, save_model

__all__ = [
    "METHODS",
    "make_model",
    "fit_log",
    "fit_file",
    "predict_log",
    "predict_drift",
    "DriftPrediction",
    "Evaluation",
    "evaluate_logs",
    "evaluate_files",
]

METHODS: tuple[str, ...] = ("mra", "grey-ls", "grey-cs", "grey-pso", "kalman")
Array = npt.NDArray[np.float64]


def make_model(method: str, *, seed: int | None = None, **options: Any) -> AnyThermalModel:
    """A fresh model for a method name of :data:`METHODS` (options go to its ``__init__``)."""
    if method == "mra":
        return MRAModel(**options)
    if method in ("grey-ls", "grey-cs", "grey-pso"):
        return GreyModel(calibration=method.removeprefix("grey-"), seed=seed, **options)
    if method == "kalman":
        return KalmanFusionModel(seed=seed, **options)
    raise ParseError(f"unknown thermal method {method!r}", hint=f"choose one of {', '.join(METHODS)}")


def _arrays(log: TemperatureLog, sel: Selection, method: str, *, allow_gaps: bool = False) -> dict[str, Array]:
    # Only the kalman model can predict through missing readings (gain 0); no model fits on them.
    kalman = method == "kalman"
    get = log.column if kalman and allow_gaps else log.require_finite
    T = np.column_stack([get(c) for c in sel.inputs])
    out = {"T": T}
    if kalman:
        if sel.speed is None:
            raise ParseError("the kalman model needs a spindle speed column", location=SourceLocation(log.source, line=1),
                             hint="name it 'spindle_speed'")
        out["speed"] = log.require_finite(sel.speed)
        out["ambient"] = log.require_finite(sel.ambient) if sel.ambient else np.zeros(log.n)
    return out


def fit_log(log: TemperatureLog, method: str, *, target: str, inputs: Sequence[str] | None = None,
            ambient: str | None = None, speed: str | None = None, seed: int | None = None,
            **options: Any) -> SavedModel:
    """Fit ``method`` on a log; the result carries its column roles and training scores."""
    sel = select_columns(log, target=target, inputs=inputs, ambient=ambient, speed=speed,
                         need_ambient=method == "kalman")
    model = make_model(method, seed=seed, **options)
    data = _arrays(log, sel, method)
    y = log.require_finite(target)
    if len(y) < 4:
        raise ParseError(f"{len(y)} samples are too few to fit a model", location=SourceLocation(log.source))
    extra = {k: v for k, v in data.items() if k != "T"}
    model.fit(data["T"], y, **extra)
    saved = SavedModel(model, sel.inputs, target, sel.ambient if method == "kalman" else None,
                       sel.speed if method == "kalman" else None, log.sample_interval_s)
    fitted = _predict(saved, log, y0=float(y[0]))
    saved.train = {"source": Path(log.source).name, "n": int(len(y)), **score(y, fitted).as_dict()}
    return saved


def fit_file(path: str | Path, method: str, *, target: str, out: str | Path | None = None,
             **kwargs: Any) -> SavedModel:
    """Read a temperature log, fit, and save to ``out`` when given."""
    saved = fit_log(read_temperature_log(path), method, target=target, **kwargs)
    if out is not None:
        save_model(saved, out)
    return saved


def _predict(saved: SavedModel, log: TemperatureLog, *, y0: float = 0.0, sensors_failed: bool = False) -> Array:
    model = saved.model
    method = getattr(model, "method", "")
    sel = Selection(saved.inputs, None, saved.ambient, saved.speed)
    for name in saved.inputs:
        log.column(name)
    data = _arrays(log, sel, method, allow_gaps=True)
    if isinstance(model, KalmanFusionModel):
        return model.predict(data["T"], ambient=data["ambient"], speed=data["speed"], sensors_failed=sensors_failed)
    return model.predict(data["T"], y0=y0)


def predict_log(saved: SavedModel, log: TemperatureLog, *, y0: float | None = None,
                sensors_failed: bool = False) -> Array:
    """Predicted thermal error for every sample of ``log`` (the target's unit).

    ``y0`` is the error at the first sample (default: the log's own target value when
    it has one, else 0 — a log starting from the cold state the model was fitted on).
    A sampling interval unlike the training one is warned about: Grey and lumped-mass
    coefficients are per sample.
    """
    interval = log.sample_interval_s
    if saved.sample_interval_s and interval and abs(interval - saved.sample_interval_s) > 0.05 * saved.sample_interval_s:
        warnings.warn(f"{log.source}: sampled every {interval:g} s but the model was fitted on "
                      f"{saved.sample_interval_s:g} s; its time constants are per sample", ParseWarning, stacklevel=2)
    if y0 is None:
        col = log.columns.get(saved.target)
        y0 = float(col[0]) if col is not None and np.isfinite(col[0]) else 0.0
    return _predict(saved, log, y0=y0, sensors_failed=sensors_failed)


@dataclass(frozen=True)
class DriftPrediction:
    """Predicted thermal drift of one log, for display beside the corrections."""

    method: str
    target: str
    timestamps: list[str]
    seconds: Array | None
    drift: Array  #: (n,) predicted thermal error, target unit
    measured: Array | None = None  #: (n,) the log's own target column when present

    @property
    def latest(self) -> float:
        """Drift at the last sample (what to show beside a correction made now)."""
        return float(self.drift[-1])


def predict_drift(model: str | Path | SavedModel, log: str | Path | TemperatureLog, *,
                  sensors_failed: bool = False) -> DriftPrediction:
    """Load a saved model (or take one) and predict the drift over a temperature log.

    ``sensors_failed`` (kalman only) ignores every reading: the lumped-mass model alone.
    """
    saved = model if isinstance(model, SavedModel) else load_model(model)
    data = log if isinstance(log, TemperatureLog) else read_temperature_log(log)
    drift = predict_log(saved, data, sensors_failed=sensors_failed)
    measured = data.columns.get(saved.target)
    return DriftPrediction(str(getattr(saved.model, "method", "")), saved.target, list(data.timestamps),
                           data.seconds, drift, measured)


@dataclass(frozen=True)
class Evaluation:
    """Training fit and test prediction of one method (``cli-json.md``, ``thermal evaluate``)."""

    method: str
    train: Scores
    test: Scores
    saved: SavedModel = field(repr=False)

    def as_json(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "rmse": self.test.rmse,
            "max_residual": self.test.max_residual,
            "efficiency": self.test.efficiency,
            "n_test": self.test.n,
            "rmsv": self.test.rmsv,
            "train_rmse": self.train.rmse,
            "n_train": self.train.n,
            "inputs": list(self.saved.inputs),
        }


def evaluate_logs(train: TemperatureLog, test: TemperatureLog, method: str, *, target: str,
                  inputs: Sequence[str] | None = None, sensors_failed: bool = False,
                  **kwargs: Any) -> Evaluation:
    """Fit on ``train``, predict ``test`` (from its own first target value), score both."""
    saved = fit_log(train, method, target=target, inputs=inputs, **kwargs)
    y = test.require_finite(target)
    predicted = predict_log(saved, test, y0=float(y[0]), sensors_failed=sensors_failed)
    train_scores = Scores(**{k: saved.train[k] for k in ("rmse", "rmsv", "max_residual", "efficiency", "n")})
    return Evaluation(method, train_scores, score(y, predicted), saved)


def evaluate_files(train: str | Path, test: str | Path, method: str, *, target: str, **kwargs: Any) -> Evaluation:
    """:func:`evaluate_logs` on two CSV files."""
    return evaluate_logs(read_temperature_log(train), read_temperature_log(test), method, target=target, **kwargs)
