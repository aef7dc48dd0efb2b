"""The saved form of a fitted thermal model: :class:`SavedModel` ↔ a JSON-ready dict.

A saved model records the method, its hyper-parameters and learned coefficients (with
the reference state: temperatures ``T_ref_`` and error ``y_ref_``), the column roles it
was fitted with (temperature inputs, target, ambient and speed columns), the sampling
interval (Grey and lumped-mass coefficients are per sample), the target's length unit,
and where its drift acts on the machine (axis and registers) for the feed-forward of
:mod:`setupfix.thermal.feedforward`.  Reading and writing the file is done by
:mod:`setupfix.inputs.thermal_files` (no file I/O at this layer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from setupfix.thermal.estimator import ThermalModel
from setupfix.thermal.registry import model_from_dict

__all__ = ["FORMAT", "VERSION", "UNITS", "SavedModel", "saved_from_dict"]

FORMAT = "setupfix-thermal-model"
VERSION = 2
#: Length units a thermal error may be given in, with their size in mm.
UNITS: dict[str, float] = {"mm": 1.0, "um": 1e-3}


@dataclass
class SavedModel:
    """A fitted model with the column roles it was fitted with.

    Attributes
    ----------
    unit : str or None
        Unit of the target (``"mm"`` or ``"um"``); None when not stated at fit time
        (such a model is refused where drift meets corrections).
    axis : str
        Machine axis the error acts along (``"Z"``: spindle growth).
    registers : tuple of str, optional
        Registers the drift moves; None means every tool-length register (spindle growth).
    """

    model: ThermalModel
    inputs: tuple[str, ...]
    target: str
    ambient: str | None = None
    speed: str | None = None
    sample_interval_s: float | None = None
    train: dict[str, Any] = field(default_factory=dict)
    unit: str | None = None
    axis: str = "Z"
    registers: tuple[str, ...] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "version": VERSION,
            "model": self.model.to_dict(),
            "inputs": list(self.inputs),
            "target": self.target,
            "unit": self.unit,
            "axis": self.axis,
            "registers": None if self.registers is None else list(self.registers),
            "ambient": self.ambient,
            "speed": self.speed,
            "sample_interval_s": self.sample_interval_s,
            "train": self.train,
        }


def _text(value: Any, key: str, *, optional: bool = False) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str) or not value:
        raise ValueError(key, "must be a non-empty string")
    return value


def saved_from_dict(data: Any) -> SavedModel:
    """Rebuild a :class:`SavedModel`; ``(key, reason)`` in a ValueError on bad content.

    Raises
    ------
    ValueError
        ``args == (key, reason)``: the entry that is missing, mistyped or inconsistent.
    ParameterError
        Unknown method or a hyper-parameter out of range.
    """
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError("format", "not a setupfix thermal model")
    version = data.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version != VERSION:
        raise ValueError(
            "version",
            f"model format version {version!r} is not supported (this setupfix reads "
            f"version {VERSION}; refit older models: they have no reference state)",
        )
    try:
        inputs = data["inputs"]
        if not isinstance(inputs, list) or not inputs or not all(isinstance(c, str) and c for c in inputs):
            raise ValueError("inputs", "must be a non-empty list of column names")
        try:
            model = model_from_dict(data["model"])
        except KeyError as exc:
            raise ValueError("model", f"missing entry {exc.args[0]!r}") from None
        except (TypeError, ValueError, AttributeError) as exc:
            raise ValueError("model", str(exc)) from None
        if model.n_inputs != len(inputs):
            raise ValueError("model", f"{model.n_inputs} reference temperatures for {len(inputs)} inputs")
        unit = data.get("unit")
        if unit is not None and unit not in UNITS:
            raise ValueError("unit", f"unit must be one of {', '.join(UNITS)}, got {unit!r}")
        registers = data.get("registers")
        if registers is not None and not (isinstance(registers, list) and all(isinstance(r, str) for r in registers)):
            raise ValueError("registers", "must be a list of register IDs or null")
        interval = data.get("sample_interval_s")
        if interval is not None and not (
            isinstance(interval, (int, float))
            and not isinstance(interval, bool)
            and math.isfinite(interval)
            and interval > 0
        ):
            raise ValueError("sample_interval_s", "must be a positive number")
        train = data.get("train", {})
        return SavedModel(
            model,
            tuple(inputs),
            str(_text(data.get("target"), "target")),
            _text(data.get("ambient"), "ambient", optional=True),
            _text(data.get("speed"), "speed", optional=True),
            None if interval is None else float(interval),
            train if isinstance(train, dict) else {},
            unit,
            str(_text(data.get("axis", "Z"), "axis")),
            None if registers is None else tuple(registers),
        )
    except KeyError as exc:
        raise ValueError(str(exc.args[0]), "missing") from None
