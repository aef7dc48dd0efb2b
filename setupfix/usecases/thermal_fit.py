"""Thermal-model use cases: fit a model on a temperature log (and save it), evaluate it on another log.

Shared by ``setupfix thermal fit|evaluate`` and the benches.  Nothing here prints: notes (warnings) come
back as data with each result.  The quality gates (E < 0 on the training or test log) are checked here,
after the engine runs; prediction is :mod:`setupfix.thermal.prediction`.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.core.errors import Note, ParameterError, ParseError, SourceLocation
from setupfix.thermal.columns import drive_arrays, select_columns, target_values
from setupfix.thermal.estimator import DEFAULT_SEED
from setupfix.thermal.metrics import Scores, score
from setupfix.thermal.persist import UNITS, SavedModel
from setupfix.thermal.prediction import Anchor, drive_notes, far_from_reference, predict_log
from setupfix.thermal.registry import get_method

__all__ = [
    "FitResult",
    "fit_log",
    "fit_file",
    "Evaluation",
    "evaluate_logs",
    "evaluate_files",
]


@dataclass
class FitResult:
    """A fitted, saved-form model and the notes of the fit."""

    saved: SavedModel
    notes: list[Note] = field(default_factory=list)


def _quality_notes(where: str, scores: Scores, source: str) -> list[Note]:
    if np.isnan(scores.efficiency):
        return [Note(f"{where} target is constant: efficiency E undefined", SourceLocation(source), "thermal")]
    if scores.efficiency < 0:
        return [
            Note(
                f"{where} efficiency E = {scores.efficiency:.3g} < 0: the model predicts worse than the "
                "mean of the measured error",
                SourceLocation(source),
                "quality",
            )
        ]
    return []


def fit_log(
    log: TemperatureLog,
    method: str,
    *,
    target: str,
    inputs: Sequence[str] | None = None,
    ambient: str | None = None,
    speed: str | None = None,
    unit: str | None = None,
    params: dict[str, Any] | None = None,
    axis: str = "Z",
    registers: Sequence[str] | None = None,
) -> FitResult:
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
    data = drive_arrays(log, sel, gaps=False)
    y = target_values(log, target)
    if len(y) < 4:
        raise ParseError(f"{len(y)} samples are too few to fit a model", location=log.location())
    if np.ptp(y) <= 1e-12 * max(float(np.max(np.abs(y))), 1e-300):
        raise ParseError(
            f"target column {target!r} is constant ({y[0]:g}): there is no thermal error to model",
            location=log.location(),
            hint="check the --target column",
        )
    drives = {"ambient": data["ambient"], "speed": data["speed"]} if spec.uses_drives else {}
    with np.errstate(all="ignore"):
        model.fit(data["T"], y, **drives)
    saved = SavedModel(
        model,
        sel.inputs,
        target,
        sel.ambient,
        sel.speed,
        log.sample_interval_s,
        unit=unit,
        axis=axis,
        registers=None if registers is None else tuple(registers),
    )
    notes = list(log.notes) + list(getattr(model, "fit_notes_", []))
    notes += drive_notes(saved, log.source)
    fitted = predict_log(saved, log)[0]
    scores = score(y, fitted)
    saved.train = {"source": Path(log.source).name, "n": len(y), "seed": params.get("seed"), **scores.as_dict()}
    notes += _quality_notes("training", scores, log.source)
    return FitResult(saved, notes)


def fit_file(
    path: str | Path,
    method: str,
    *,
    target: str,
    out: str | Path | None = None,
    interval: float | None = None,
    sheet: str | None = None,
    **kwargs: Any,
) -> FitResult:
    """Read a temperature log, fit, and save to ``out`` when given."""
    from setupfix.inputs.thermal_files import save_model

    result = fit_log(read_temperature_log(path, interval=interval, sheet=sheet), method, target=target, **kwargs)
    if out is not None:
        save_model(result.saved, out)
    return result


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


def evaluate_logs(
    train: TemperatureLog,
    test: TemperatureLog,
    method: str,
    *,
    target: str,
    sensors_failed: bool = False,
    anchor: Anchor | None = None,
    **kwargs: Any,
) -> Evaluation:
    """Fit on ``train``, predict ``test`` relative to the reference state, score both."""
    fitted = fit_log(train, method, target=target, **kwargs)
    saved = fitted.saved
    y = target_values(test, target)
    predicted, notes = predict_log(saved, test, sensors_failed=sensors_failed, anchor=anchor)
    far = far_from_reference(saved, test)
    train_scores = Scores(**{k: saved.train[k] for k in ("rmse", "rmsv", "max_residual", "efficiency", "n")})
    test_scores = score(y, predicted)
    all_notes = fitted.notes + list(test.notes) + notes + ([far] if far else [])
    all_notes += _quality_notes("test", test_scores, test.source)
    return Evaluation(saved.model.name, train_scores, test_scores, saved, tuple(all_notes))


def evaluate_files(
    train: str | Path,
    test: str | Path,
    method: str,
    *,
    target: str,
    interval: float | None = None,
    sheet: str | None = None,
    **kwargs: Any,
) -> Evaluation:
    """:func:`evaluate_logs` on two log files."""
    return evaluate_logs(
        read_temperature_log(train, interval=interval, sheet=sheet),
        read_temperature_log(test, interval=interval, sheet=sheet),
        method,
        target=target,
        **kwargs,
    )
