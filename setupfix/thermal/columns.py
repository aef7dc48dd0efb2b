"""The columns of a temperature log and their roles: temperature inputs, target, ambient and speed.

:func:`select_columns` resolves the roles (``cli-json.md``, ``thermal evaluate``); the readers below return
a column's values checked for plausibility (temperatures within [−273.15, 2000] °C, errors and speeds
within ±1e6), for the thermal use cases of :mod:`setupfix.thermal.prediction` and
:mod:`setupfix.usecases.thermal_fit`.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from parsers.temperature import TemperatureLog
from setupfix.core.errors import ParameterError, ParseError

__all__ = [
    "Selection",
    "select_columns",
]

Array = npt.NDArray[np.float64]
SPEED = "spindle_speed"
AMBIENT = "ambient"
#: Plausible range of a temperature (°C or K of rise); outside it a cell is refused.
TEMPERATURE_RANGE = (-273.15, 2000.0)
#: Largest magnitude of a thermal error or a spindle speed accepted.
VALUE_LIMIT = 1e6


@dataclass(frozen=True)
class Selection:
    """Which columns of a log play which role."""

    inputs: tuple[str, ...]
    target: str | None
    ambient: str | None = None
    speed: str | None = None


def select_columns(
    log: TemperatureLog,
    *,
    target: str | None,
    inputs: Sequence[str] | None = None,
    ambient: str | None = None,
    speed: str | None = None,
    drives: bool = False,
) -> Selection:
    """Resolve the roles of the columns (``cli-json.md``, ``thermal evaluate``).

    Temperature inputs are every numeric column but the target, the speed and the
    ambient one unless ``inputs`` names them.  With ``drives`` (kalman) the speed column
    defaults to ``spindle_speed`` and the ambient one to ``ambient`` when present;
    either may be absent (the model's documented fallback).  A column may play one
    role only.
    """
    loc = log.location()
    if target is not None and target not in log.columns:
        raise ParseError(
            f"target column {target!r} not found or not numeric",
            location=loc,
            hint=f"numeric columns: {', '.join(log.columns)}",
        )
    for role, name in (("speed", speed), ("ambient", ambient)):
        if name is not None and name not in log.columns:
            raise ParseError(
                f"{role} column {name!r} not found or not numeric",
                location=loc,
                hint=f"numeric columns: {', '.join(log.columns)}",
            )
    if drives:
        speed = speed or (SPEED if SPEED in log.columns else None)
        ambient = ambient or (AMBIENT if AMBIENT in log.columns else None)
    elif ambient is not None or speed is not None:
        raise ParameterError("--ambient and --speed are inputs of the kalman method only")
    if inputs:
        missing = [c for c in inputs if c not in log.columns]
        if missing:
            raise ParseError(
                f"input column {missing[0]!r} not found or not numeric",
                location=loc,
                hint=f"numeric columns: {', '.join(log.columns)}",
            )
        if len(set(inputs)) != len(inputs):
            raise ParameterError(f"an input column is named twice in {', '.join(inputs)}")
        chosen = tuple(inputs)
    else:
        skip = {target, speed, ambient, SPEED}
        chosen = tuple(c for c in log.columns if c not in skip)
    roles = {"target": target, "speed": speed, "ambient": ambient}
    for role, name in roles.items():
        if name is not None and name in chosen:
            raise ParameterError(
                f"column {name!r} is both the {role} and a temperature input", hint="a column plays one role only"
            )
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
        raise ParseError(
            f"{what} {values[i]:g} in column {name!r} is outside [{low:g}, {high:g}]",
            location=log.location(i),
            hint="a sensor fault or a wrong column",
        )
    return values


def drive_arrays(log: TemperatureLog, sel: Selection, *, gaps: bool) -> dict[str, Any]:
    T = np.column_stack(
        [
            _checked(log, c, gaps=gaps, low=TEMPERATURE_RANGE[0], high=TEMPERATURE_RANGE[1], what="temperature")
            for c in sel.inputs
        ]
    )
    ambient = (
        None
        if sel.ambient is None
        else _checked(
            log, sel.ambient, gaps=False, low=TEMPERATURE_RANGE[0], high=TEMPERATURE_RANGE[1], what="temperature"
        )
    )
    speed = (
        None
        if sel.speed is None
        else _checked(log, sel.speed, gaps=False, low=-VALUE_LIMIT, high=VALUE_LIMIT, what="speed")
    )
    return {"T": T, "ambient": ambient, "speed": speed}


def target_values(log: TemperatureLog, name: str) -> Array:
    return _checked(log, name, gaps=False, low=-VALUE_LIMIT, high=VALUE_LIMIT, what="error")
