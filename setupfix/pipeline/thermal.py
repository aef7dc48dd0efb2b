"""Thermal-drift use cases: fit a model on a temperature log, evaluate it, predict drift.

Shared by ``setupfix thermal fit|predict|evaluate``, ``setupfix correct --thermal``
and the operator TUI.  Nothing here prints: notes (warnings) come back as data with
each result.  Column roles, plausibility of the values (temperatures within
[−273.15, 2000] °C, errors and speeds within ±1e6) and the quality gates (E < 0 on
the training or test log) are checked here, before and after the engine runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.errors import Note, ParameterError, ParseError, SourceLocation
from setupfix.thermal.metrics import Scores, score
from setupfix.thermal.estimator import DEFAULT_SEED, rebase
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.persist import UNITS, SavedModel
from setupfix.thermal.registry import get_method, methods

__all__ = [
    "methods",
    "Selection",
    "select_columns",
    "Anchor",
    "parse_anchor",
    "FitResult",
    "fit_log",
    "fit_file",
    "predict_log",
    "predict_drift",
    "DriftPrediction",
    "Evaluation",
    "evaluate_logs",
    "evaluate_files",
]

Array = npt.NDArray[np.float64]
SPEED = "spindle_speed"
AMBIENT = "ambient"
#: Plausible range of a temperature (°C or K of rise); outside it a cell is refused.
TEMPERATURE_RANGE = (-273.15, 2000.0)
#: Largest magnitude of a thermal error or a spindle speed accepted.
VALUE_LIMIT = 1e6
#: Distance from the reference state (K) beyond which ``evaluate`` warns.
FAR_FROM_REFERENCE_K = 2.0


@dataclass(frozen=True)
class Selection:
    """Which columns of a log play which role."""

    inputs: tuple[str, ...]
    target: str | None
    ambient: str | None = None
    speed: str | None = None


def select_columns(log: TemperatureLog, *, target: str | None, inputs: Sequence[str] | None = None,
                   ambient: str | None = None, speed: str | None = None, drives: bool = False) -> Selection:
    """Resolve the roles of the columns (``cli-json.md``, ``thermal evaluate``).

    Temperature inputs are every numeric column but the target, the speed and the
    ambient one unless ``inputs`` names them.  With ``drives`` (kalman) the speed column
    defaults to ``spindle_speed`` and the ambient one to ``ambient`` when present;
    either may be absent (the model's documented fallback).  A column may play one
    role only.
    """
    loc = log.location()
    if target is not None and target not in log.columns:
        raise ParseError(f"target column {target!r} not found or not numeric", location=loc,
                         hint=f"numeric columns: {', '.join(log.columns)}")
    for role, name in (("speed", speed), ("ambient", ambient)):
        if name is not None and name not in log.columns:
            raise ParseError(f"{role} column {name!r} not found or not numeric", location=loc,
                             hint=f"numeric columns: {', '.join(log.columns)}")
    if drives:
        speed = speed or (SPEED if SPEED in log.columns else None)
        ambient = ambient or (AMBIENT if AMBIENT in log.columns else None)
    elif ambient is not None or speed is not None:
        raise ParameterError("--ambient and --speed are inputs of the kalman method only")
    if inputs:
        missing = [c for c in inputs if c not in log.columns]
        if missing:
            raise ParseError(f"input column {missing[0]!r} not found or not numeric", location=loc,
                             hint=f"numeric columns: {', '.join(log.columns)}")
        if len(set(inputs)) != len(inputs):
            raise ParameterError(f"an input column is named twice in {', '.join(inputs)}")
        chosen = tuple(inputs)
    else:
        skip = {target, speed, ambient, SPEED}
        chosen = tuple(c for c in log.columns if c not in skip)
    roles = {"target": target, "speed": speed, "ambient": ambient}
    for role, name in roles.items():
        if name is not None and name in chosen:
            raise ParameterError(f"column {name!r} is both the {role} and a temperature input",
                                 hint="a column plays one role only")
    if target is not None and target in (speed, ambient):
        raise ParameterError(f"column {target!r} is both the target and a drive")
    if not chosen:
        raise ParseError("no temperature columns", location=loc)
    return Selection(chosen, target, ambient, speed)


def _checked(log: TemperatureLog, name: str, *, gaps: bool, low: float, high: float, what: str) -> Array:
    values = log.column(name) if gaps else log.require_finite(name)
    bad = np.flatnonzero(np.isfinite(values) & ((values < low) | (values > high)))
    if bad.size:
        i = int(bad[0])
        raise ParseError(f"{what} {values[i]:g} in column {name!r} is outside [{low:g}, {high:g}]",
                         location=log.location(i), hint="a sensor fault or a wrong column")
    return values


def _drive_arrays(log: TemperatureLog, sel: Selection, *, gaps: bool) -> dict[str, Any]:
    T = np.column_stack([_checked(log, c, gaps=gaps, low=TEMPERATURE_RANGE[0], high=TEMPERATURE_RANGE[1],
                                  what="temperature") for c in sel.inputs])
    ambient = None if sel.ambient is None else _checked(log, sel.ambient, gaps=False, low=TEMPERATURE_RANGE[0],
                                                          high=TEMPERATURE_RANGE[1], what="temperature")
    speed = None if sel.speed is None else _checked(log, sel.speed, gaps=False, low=-VALUE_LIMIT,
                                                      high=VALUE_LIMIT, what="speed")
    return {"T": T, "ambient": ambient, "speed": speed}


def _target(log: TemperatureLog, name: str) -> Array:
    return _checked(log, name, gaps=False, low=-VALUE_LIMIT, high=VALUE_LIMIT, what="error")


@dataclass
class FitResult:
    """A fitted, saved-form model and the notes of the fit."""

    saved: SavedModel
    notes: list[Note] = field(default_factory=list)


def _quality_notes(where: str, scores: Scores, source: str) -> list[Note]:
    if np.isnan(scores.efficiency):
        return [Note(f"{where} target is constant: efficiency E undefined", SourceLocation(source), "thermal")]
    if scores.efficiency < 0:
        return [Note(f"{where} efficiency E = {scores.efficiency:.3g} < 0: the model predicts worse than the "
                     "mean of the measured error", SourceLocation(source), "quality")]
    return []


def fit_log(log: TemperatureLog, method: str, *, target: str, inputs: Sequence[str] | None = None,
            ambient: str | None = None, speed: str | None = None, unit: str | None = None,
            params: dict[str, Any] | None = None, axis: str = "Z",
            registers: Sequence[str] | None = None) -> FitResult:
    """Fit ``method`` on a log; the result carries its column roles, unit and training scores.

    ``params`` are the method's hyper-parameters (validated before any work); a
    stochastic method without ``seed`` gets :data:`DEFAULT_SEED`.
    """
    spec = get_method(method)
    params = dict(params or {})
    if spec.stochastic:
        params.setdefault("seed", DEFAULT_SEED)
    model = spec.make(**params)
    if unit is not None and unit not in UNITS:
        raise ParameterError(f"unit must be one of {', '.join(UNITS)}, got {unit!r}")
    sel = select_columns(log, target=target, inputs=inputs, ambient=ambient, speed=speed, drives=spec.uses_drives)
    data = _drive_arrays(log, sel, gaps=False)
    y = _target(log, target)
    if len(y) < 4:
        raise ParseError(f"{len(y)} samples are too few to fit a model", location=log.location())
    if np.ptp(y) <= 1e-12 * max(float(np.max(np.abs(y))), 1e-300):
        raise ParseError(f"target column {target!r} is constant ({y[0]:g}): there is no thermal error to model",
                         location=log.location(), hint="check the --target column")
    drives = {"ambient": data["ambient"], "speed": data["speed"]} if spec.uses_drives else {}
    with np.errstate(all="ignore"):
        model.fit(data["T"], y, **drives)
    saved = SavedModel(model, sel.inputs, target, sel.ambient, sel.speed, log.sample_interval_s,
                       unit=unit, axis=axis, registers=None if registers is None else tuple(registers))
    notes = list(log.notes) + list(getattr(model, "fit_notes_", []))
    notes += _drive_notes(saved, log.source)
    fitted = predict_log(saved, log)[0]
    scores = score(y, fitted)
    saved.train = {"source": Path(log.source).name, "n": len(y), "seed": params.get("seed"),
                   **scores.as_dict()}
    notes += _quality_notes("training", scores, log.source)
    return FitResult(saved, notes)


def _drive_notes(saved: SavedModel, source: str) -> list[Note]:
    if not isinstance(saved.model, KalmanFusionModel):
        return []
    out = []
    if saved.speed is None:
        out.append(Note("kalman without a spindle speed: lumped masses exchange heat with the ambient only "
                        "(no heat input); give --speed COL when the log has one", SourceLocation(source), "fallback"))
    if saved.ambient is None:
        out.append(Note(f"kalman without an ambient column: ambient taken as constant "
                        f"{saved.model.ambient_const_:.4g} (median reference temperature)", SourceLocation(source),
                        "fallback"))
    return out


def fit_file(path: str | Path, method: str, *, target: str, out: str | Path | None = None,
             interval: float | None = None, sheet: str | None = None, **kwargs: Any) -> FitResult:
    """Read a temperature log, fit, and save to ``out`` when given."""
    from setupfix.pipeline.thermal_files import save_model

    result = fit_log(read_temperature_log(path, interval=interval, sheet=sheet), method, target=target, **kwargs)
    if out is not None:
        save_model(result.saved, out)
    return result


@dataclass(frozen=True)
class Anchor:
    """A measured error that re-bases a prediction: at ``time`` (ISO timestamp or sample number) or ``first``."""

    time: str
    error: float | None = None


def parse_anchor(text: str) -> Anchor:
    """``first`` or ``TIME=ERROR`` (``--anchor``); :class:`ParameterError` otherwise."""
    text = text.strip()
    if text == "first":
        return Anchor("first")
    time, sep, value = text.rpartition("=")
    from parsers.temperature.reader import strict_number

    number = strict_number(value) if sep else None
    if not time.strip() or number is None:
        raise ParameterError(f"--anchor must be 'first' or TIME=ERROR, got {text!r}",
                             hint="e.g. --anchor 2026-01-05T08:00:00=0.004")
    return Anchor(time.strip(), number)


def sample_at(log: TemperatureLog, time: str) -> int:
    """Index of the last sample at or before ``time`` (ISO timestamp, or a sample number without timestamps)."""
    if log.timestamps:
        try:
            when = datetime.fromisoformat(time.replace("Z", "+00:00"))
            stamps = [datetime.fromisoformat(s.replace("Z", "+00:00")) for s in log.timestamps]
            idx = int(np.searchsorted(np.array([(s - stamps[0]).total_seconds() for s in stamps]),
                                      (when - stamps[0]).total_seconds(), side="right")) - 1
        except (ValueError, TypeError):
            raise ParameterError(f"time {time!r} is not an ISO 8601 time comparable with the log's timestamps",
                                 hint="e.g. 2026-01-05T08:00:00") from None
    else:
        if not time.isdigit():
            raise ParameterError(f"the log has no timestamps: give a sample number, not {time!r}")
        idx = int(time)
    if idx < 0 or idx >= log.n:
        raise ParameterError(f"time {time} is outside the log ({log.source}: samples 0–{log.n - 1})")
    return idx


def predict_log(saved: SavedModel, log: TemperatureLog, *, anchor: Anchor | None = None,
                sensors_failed: bool = False) -> tuple[Array, list[Note]]:
    """Predicted thermal error for every sample of ``log`` (the target's unit) and the notes.

    Relative to the model's reference state; ``anchor`` re-bases it on a measured
    error.  A sampling interval unlike the training one is noted: Grey and lumped-mass
    coefficients are per sample.
    """
    notes: list[Note] = []
    interval = log.sample_interval_s
    trained = saved.sample_interval_s
    if trained and interval and abs(interval - trained) > 0.05 * trained:
        notes.append(Note(f"sampled every {interval:g} s but the model was fitted on {trained:g} s; "
                          "its time constants are per sample", log.location(), "thermal"))
    sel = Selection(saved.inputs, None, saved.ambient, saved.speed)
    data = _drive_arrays(log, sel, gaps=isinstance(saved.model, KalmanFusionModel))
    drives = {"ambient": data["ambient"], "speed": data["speed"]} if isinstance(saved.model, KalmanFusionModel) else {}
    with np.errstate(all="ignore"):
        pred = saved.model.predict(data["T"], sensors_failed=sensors_failed, **drives)
    if anchor is not None:
        if anchor.time == "first":
            measured = log.columns.get(saved.target)
            if measured is None or not np.isfinite(measured[0]):
                raise ParseError(f"--anchor first needs the error column {saved.target!r} at the first sample",
                                 location=log.location(0))
            pred = rebase(pred, 0, float(measured[0]))
        else:
            pred = rebase(pred, sample_at(log, anchor.time), float(anchor.error))  # type: ignore[arg-type]  # anchor.time is a timestamp on this branch
    if not np.all(np.isfinite(pred)):
        raise ParseError(f"the {saved.model.name} model diverges on this log (non-finite prediction)",
                         location=log.location(), hint="refit, or use mra")
    return pred, notes


def far_from_reference(saved: SavedModel, log: TemperatureLog) -> Note | None:
    """A note when the log's first temperatures are more than :data:`FAR_FROM_REFERENCE_K` from the reference."""
    first = np.array([log.columns[c][0] if c in log.columns else np.nan for c in saved.inputs])
    gap = np.abs(first - saved.model.T_ref_)
    if np.any(np.isfinite(gap)) and np.nanmax(gap) > FAR_FROM_REFERENCE_K:
        j = int(np.nanargmax(gap))
        return Note(f"the log starts {gap[j]:.3g} K from the model's reference state ({saved.inputs[j]}): "
                    "predicted relative to the reference; dynamic models start from these temperatures",
                    log.location(0), "thermal")
    return None


@dataclass(frozen=True)
class DriftPrediction:
    """Predicted thermal drift of one log, for display beside the corrections."""

    method: str
    target: str
    unit: str | None
    timestamps: list[str]
    seconds: Array | None
    drift: Array  #: (n,) predicted thermal error relative to the reference state, target unit
    measured: Array | None = None  #: (n,) the log's own target column when present
    notes: tuple[Note, ...] = ()

    @property
    def latest(self) -> float:
        """Predicted error at the last sample, relative to the model's reference state.

        Not what to add to a correction: the last correction already absorbed the
        drift up to the time its measured parts were cut (see
        :func:`setupfix.thermal.feedforward.drift_change`).
        """
        return float(self.drift[-1])

    @property
    def rmse(self) -> float | None:
        """RMS error of the prediction against the log's own target column (None without one)."""
        if self.measured is None:
            return None
        from setupfix.thermal.metrics import score

        return float(score(self.measured, self.drift).rmse)


def predict_drift(model: str | Path | SavedModel, log: str | Path | TemperatureLog, *,
                  sensors_failed: bool = False, anchor: Anchor | None = None,
                  interval: float | None = None) -> DriftPrediction:
    """Load a saved model (or take one) and predict the drift over a temperature log."""
    from setupfix.pipeline.thermal_files import load_model

    saved = model if isinstance(model, SavedModel) else load_model(model)
    data = log if isinstance(log, TemperatureLog) else read_temperature_log(
        log, interval=interval if interval is not None else saved.sample_interval_s, require_time=False)
    drift, notes = predict_log(saved, data, sensors_failed=sensors_failed, anchor=anchor)
    notes = list(data.notes) + _drive_notes(saved, data.source) + notes
    if not data.timestamps and interval is None and saved.sample_interval_s is not None:
        notes.append(Note(f"no timestamp: samples taken {saved.sample_interval_s:g} s apart, as in training",
                          data.location(), "thermal"))
    measured = data.columns.get(saved.target)
    return DriftPrediction(saved.model.name, saved.target, saved.unit, list(data.timestamps), data.seconds, drift,
                           measured, tuple(notes))


@dataclass(frozen=True)
class Evaluation:
    """Training fit and test prediction of one method (``cli-json.md``, ``thermal evaluate``)."""

    method: str
    train: Scores
    test: Scores
    saved: SavedModel = field(repr=False)
    notes: tuple[Note, ...] = ()

    def as_json(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "rmse": self.test.rmse,
            "max_residual": self.test.max_residual,
            "efficiency": self.test.efficiency,
            "n_test": self.test.n,
            "rmsv": self.test.rmsv,
            "train_rmse": self.train.rmse,
            "train_efficiency": self.train.efficiency,
            "n_train": self.train.n,
            "inputs": list(self.saved.inputs),
            "unit": self.saved.unit,
            "seed": self.saved.train.get("seed"),
            "warnings": [str(n) for n in self.notes if n.kind in ("quality", "fallback", "thermal")],
        }


def evaluate_logs(train: TemperatureLog, test: TemperatureLog, method: str, *, target: str,
                  sensors_failed: bool = False, anchor: Anchor | None = None, **kwargs: Any) -> Evaluation:
    """Fit on ``train``, predict ``test`` relative to the reference state, score both."""
    fitted = fit_log(train, method, target=target, **kwargs)
    saved = fitted.saved
    y = _target(test, target)
    predicted, notes = predict_log(saved, test, sensors_failed=sensors_failed, anchor=anchor)
    far = far_from_reference(saved, test)
    train_scores = Scores(**{k: saved.train[k] for k in ("rmse", "rmsv", "max_residual", "efficiency", "n")})
    test_scores = score(y, predicted)
    all_notes = fitted.notes + list(test.notes) + notes + ([far] if far else [])
    all_notes += _quality_notes("test", test_scores, test.source)
    return Evaluation(saved.model.name, train_scores, test_scores, saved, tuple(all_notes))


def evaluate_files(train: str | Path, test: str | Path, method: str, *, target: str, interval: float | None = None,
                   sheet: str | None = None, **kwargs: Any) -> Evaluation:
    """:func:`evaluate_logs` on two log files."""
    return evaluate_logs(read_temperature_log(train, interval=interval, sheet=sheet),
                         read_temperature_log(test, interval=interval, sheet=sheet), method, target=target, **kwargs)
