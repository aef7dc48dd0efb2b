"""Thermal models to and from JSON, with a format version.

The document holds the method, its hyper-parameters and learned coefficients (from
``to_dict`` of :mod:`setupfix.thermal.models`) and the context needed to apply it to
another log: the input columns, the target, the ambient and speed columns and the
sampling interval (Grey and lumped-mass coefficients are per sample).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from setupfix.atomic import atomic_write
from setupfix.errors import ExportError, ParseError, SourceLocation
from setupfix.thermal.models import AnyThermalModel, GreyModel, KalmanFusionModel, MRAModel

__all__ = ["FORMAT", "VERSION", "SavedModel", "save_model", "load_model", "model_from_dict"]

FORMAT = "setupfix-thermal-model"
VERSION = 1


@dataclass
class SavedModel:
    """A fitted model with the column roles it was fitted with."""

    model: AnyThermalModel
    inputs: tuple[str, ...]
    target: str
    ambient: str | None = None
    speed: str | None = None
    sample_interval_s: float | None = None
    train: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "version": VERSION,
            "model": self.model.to_dict(),
            "inputs": list(self.inputs),
            "target": self.target,
            "ambient": self.ambient,
            "speed": self.speed,
            "sample_interval_s": self.sample_interval_s,
            "train": self.train,
        }


def model_from_dict(data: dict[str, Any]) -> AnyThermalModel:
    """Rebuild a model from its ``to_dict`` form (KeyError/TypeError on bad content)."""
    method = data["method"]
    if method == "mra":
        return MRAModel.from_dict(data)
    if method == "kalman":
        return KalmanFusionModel.from_dict(data)
    if method.startswith("grey-"):
        return GreyModel.from_dict(data)
    raise KeyError(f"unknown method {method!r}")


def save_model(saved: SavedModel, path: str | Path) -> None:
    """Write ``saved`` as JSON through :func:`~setupfix.atomic.atomic_write`."""
    try:
        text = json.dumps(saved.to_dict(), indent=2, allow_nan=False, default=_plain)
    except ValueError:
        raise ExportError("the fitted model has non-finite coefficients and is not saved",
                          location=SourceLocation(str(path)), hint="the calibration diverged; try grey-ls or mra") from None
    with atomic_write(path, newline="\n") as stream:
        stream.write(text + "\n")


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot store {type(value).__name__}")


def load_model(path: str | Path) -> SavedModel:
    """Read a model written by :func:`save_model`.

    Raises
    ------
    ParseError
        Not JSON, another format or a newer version, or a missing or bad key — naming the key.
    """
    source = str(path)
    try:
        with open(path, encoding="utf-8") as stream:
            data = json.load(stream)
    except OSError as exc:
        raise ParseError(f"cannot read: {exc.strerror}", location=SourceLocation(source)) from None
    except json.JSONDecodeError as exc:
        raise ParseError(f"not JSON: {exc.msg}", location=SourceLocation(source, line=exc.lineno)) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ParseError("not a setupfix thermal model", location=SourceLocation(source, key="format"),
                         hint="write one with 'setupfix thermal fit'")
    version = data.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise ParseError(f"model format version {version!r} is not supported (this setupfix reads up to {VERSION})",
                         location=SourceLocation(source, key="version"))
    try:
        model = model_from_dict(data["model"])
        inputs = tuple(str(c) for c in data["inputs"])
        target = str(data["target"])
    except KeyError as exc:
        raise ParseError(f"missing or bad entry {exc.args[0]!r}", location=SourceLocation(source, key="model")) from None
    except (TypeError, ValueError) as exc:
        raise ParseError(f"bad model content: {exc}", location=SourceLocation(source, key="model")) from None
    interval = data.get("sample_interval_s")
    if interval is not None and not (isinstance(interval, (int, float)) and math.isfinite(interval) and interval > 0):
        raise ParseError("sample_interval_s must be a positive number",
                         location=SourceLocation(source, key="sample_interval_s"))
    return SavedModel(model, inputs, target, data.get("ambient"), data.get("speed"),
                      None if interval is None else float(interval), data.get("train", {}))
