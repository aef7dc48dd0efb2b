"""Drift fed forward: the thermal change since the measured parts were cut, as a register correction.

``setupfix correct --thermal MODEL.json --temperatures LOG`` adds the line this module
builds beside the setup correction (a step of :func:`setupfix.usecases.correct.correct_cycle`)
("thermal feed-forward −0.004 mm on H5, H23").  The
arithmetic is :mod:`setupfix.thermal.feedforward` (pure); here the files are read, the
times joined, the registers and units resolved, and the result described.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.core.errors import Note, ParameterError, ParseError, SourceLocation
from setupfix.model.process import ProcessModel
from setupfix.thermal.feedforward import drift_change, feed_forward
from setupfix.thermal.persist import UNITS, SavedModel

__all__ = ["ThermalFeedForward", "thermal_feed_forward", "moved_registers", "unit_factor"]

_MM_PER: dict[str, float] = {"mm": 1.0, "inch": 25.4}


def unit_factor(thermal_unit: str | None, process_unit: str, source: str = "thermal model") -> float:
    """Length of one thermal-model unit in the process model's unit (µm → mm: 0.001)."""
    if thermal_unit is None:
        raise ParseError(
            "the thermal model does not state the unit of its error",
            location=SourceLocation(source),
            hint="refit it with --unit um or --unit mm",
        )
    return UNITS[thermal_unit] / _MM_PER[process_unit]


def moved_registers(model: ProcessModel, saved: SavedModel, source: str = "thermal model") -> np.ndarray:
    """Mask (R,) of the process-model registers the drift moves (default: every free tool register)."""
    regs = model.registers
    if saved.axis.upper() != str(model.axis).upper():
        raise ParameterError(
            f"the thermal model acts along {saved.axis}, the process model along {model.axis}",
            hint=f"{source}: refit with --axis {model.axis} if the drift acts on this axis",
        )
    if saved.registers is None:
        mask = np.array([r.kind == "tool" and not r.fixed for r in regs])
    else:
        names = {k.strip().lower() for k in saved.registers}
        mask = np.array([(r.id.lower() in names or r.register.lower() in names) and not r.fixed for r in regs])
        known = {r.id.lower() for r in regs} | {r.register.lower() for r in regs}
        unknown = sorted(names - known)
        if unknown:
            raise ParseError(
                f"register {unknown[0]!r} of the thermal model is not in the process model",
                location=SourceLocation(source, key="registers"),
            )
    if not mask.any():
        raise ParameterError(
            "the thermal drift moves no free register of the process model",
            hint=f"{source}: name them with thermal fit --registers",
        )
    return mask


def _seconds(stamp: str, origin: datetime, what: str) -> float:
    try:
        return (datetime.fromisoformat(stamp.strip().replace("Z", "+00:00")) - origin).total_seconds()
    except (ValueError, TypeError):
        raise ParameterError(
            f"{what} {stamp!r} is not an ISO 8601 time comparable with the temperature log's",
            hint="e.g. 2026-01-05T08:00:00, both with or both without a time zone",
        ) from None


@dataclass(frozen=True)
class ThermalFeedForward:
    """The thermal line of a recommendation.

    Attributes
    ----------
    delta : float
        ΔE since the measured parts were cut, thermal-model unit.
    shift : float
        Correction added to each moved register (−ΔE in the process unit, on the
        register grid); 0 inside the dead band.
    registers : tuple of str
        Model IDs of the moved registers; ``names`` their controller names.
    """

    method: str
    delta: float
    thermal_unit: str
    shift: float
    process_unit: str
    registers: tuple[str, ...]
    names: tuple[str, ...]
    measured_at: str
    at: str
    dead_band: float
    notes: tuple[Note, ...] = field(default=())

    @property
    def applied(self) -> bool:
        return self.shift != 0.0

    def corrections(self) -> dict[str, float]:
        """Register ID → correction (empty inside the dead band)."""
        return {r: self.shift for r in self.registers} if self.applied else {}

    def line(self) -> str:
        unit = self.thermal_unit.replace("um", "µm")
        change = f"ΔE {self.delta:+.4g} {unit} since {self.measured_at} ({self.method}, to {self.at})"
        if not self.applied:
            return f"thermal feed-forward: none ({change} within the dead band ±{self.dead_band:g} {self.process_unit})"
        return f"thermal feed-forward {self.shift:+.4g} {self.process_unit} on {', '.join(self.names)} ({change})"

    def to_json(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "delta": self.delta,
            "delta_unit": self.thermal_unit,
            "shift": self.shift,
            "unit": self.process_unit,
            "registers": list(self.registers),
            "applied": self.applied,
            "measured_at": self.measured_at,
            "at": self.at,
            "dead_band": self.dead_band,
            "corrections": self.corrections(),
        }


def thermal_feed_forward(
    model: ProcessModel,
    thermal: str | Path | SavedModel,
    log: str | Path | TemperatureLog,
    *,
    measured_at: str | None,
    at: str | None = None,
    dead_band: float | None = None,
) -> ThermalFeedForward:
    """The feed-forward of a thermal model over a temperature log (module docstring).

    Parameters
    ----------
    model : ProcessModel
    thermal : path or SavedModel
    log : path or TemperatureLog
        With timestamps (the parts' time is joined to them).
    measured_at : str
        Timestamp of the measured parts (from the report).
    at : str, optional
        Time of the correction (default: the log's last sample).
    dead_band : float, optional
        Process-model unit; default one register step (``model.resolution``).

    Raises
    ------
    ParseError, ParameterError
        No unit in the thermal model, no timestamps in the log or the report, a time
        outside the log, registers or axis that do not fit the process model.
    """
    from setupfix.inputs.thermal_files import load_model
    from setupfix.thermal.prediction import predict_log

    source = str(thermal) if not isinstance(thermal, SavedModel) else "thermal model"
    saved = thermal if isinstance(thermal, SavedModel) else load_model(thermal)
    factor = unit_factor(saved.unit, model.unit, source)
    mask = moved_registers(model, saved, source)
    data = log if isinstance(log, TemperatureLog) else read_temperature_log(log)
    if not data.timestamps:
        raise ParseError(
            "the temperature log has no timestamps: the measured parts cannot be joined to it", location=data.location()
        )
    if not measured_at:
        raise ParameterError(
            "the report gives no timestamp for its parts: the thermal change since they were cut is unknown",
            hint="add a timestamp column to the report",
        )
    origin = datetime.fromisoformat(data.timestamps[0].replace("Z", "+00:00"))
    times = np.array([_seconds(s, origin, "log time") for s in data.timestamps])
    t_meas = _seconds(measured_at, origin, "part timestamp")
    t_at = None if at is None else _seconds(at, origin, "--at")
    drift, notes = predict_log(saved, data)
    try:
        delta = float(drift_change(drift, times, t_meas, t_at))
    except ValueError as exc:
        raise ParameterError(
            f"{exc} ({data.source}: {data.timestamps[0]} … {data.timestamps[-1]}; "
            f"parts cut {measured_at}{'' if at is None else f', correction at {at}'})"
        ) from None
    band = float(model.resolution if dead_band is None else dead_band)
    if not np.isfinite(band) or band < 0:
        raise ParameterError(f"the thermal dead band must be a number >= 0, got {band!r}")
    x = feed_forward(delta, mask, factor=factor, resolution=model.resolution, dead_band=band)
    regs = [r for r, m in zip(model.registers, mask, strict=True) if m]
    at_text = at if at is not None else data.timestamps[-1]
    return ThermalFeedForward(
        saved.model.name,
        delta,
        str(saved.unit),
        float(x[mask][0]),
        model.unit,
        tuple(r.id for r in regs),
        tuple(r.register for r in regs),
        measured_at,
        at_text,
        band,
        tuple(list(data.notes) + notes),
    )
