"""The model's register components as the control's :class:`~setupfix.links.base.Component` s,
and the conversion between the model's unit and the control's at the control's increment.

One-axis model: a WKS register (``W1``, ``G54``) acts along ``process.axis``, so it is the
component ``(G54, axis)``; a tool register is its length (``(H5, length)``).  Multi-axis model:
a WKS component ``W1.X`` is ``(G54, X)``, ``W1.C`` the rotation ``(G54, C)`` in degrees; a tool
length ``T5`` is ``(H5, length)`` and a tool radius ``T5.R`` is ``(D5, radius)``.  Fixed registers
are never written, so they are not components of a write.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from setupfix.core.units import length_factor
from setupfix.links.base import LENGTH, RADIUS, Component
from setupfix.model import ProcessModel, Register

__all__ = [
    "component_of",
    "model_components",
    "to_control",
    "to_model",
    "round_to_increment",
    "decimals_of",
    "current_from_control",
]


def component_of(model: ProcessModel, reg: Register) -> Component:
    """The control's component a model register (component) writes to."""
    if reg.kind == "wks":
        return Component(reg.register, reg.component if reg.component is not None else model.axis)
    return Component(reg.register, RADIUS if reg.component == "R" else LENGTH)


def model_components(model: ProcessModel) -> dict[str, Component]:
    """Model register ID → component, for every correctable (not fixed) register, model order."""
    return {reg.id: component_of(model, reg) for reg in model.registers if not reg.fixed}


def to_control(value: float, component: Component, model_unit: str, control_unit: str) -> float:
    """A value in the model's unit in the control's (a rotation stays in degrees)."""
    return value if component.rotation else value * length_factor(model_unit, control_unit)


def to_model(value: float, component: Component, model_unit: str, control_unit: str) -> float:
    """A value in the control's unit in the model's (a rotation stays in degrees)."""
    return value if component.rotation else value * length_factor(control_unit, model_unit)


def decimals_of(increment: float) -> int:
    """Decimals that show a whole multiple of ``increment`` exactly (0.001 → 3, 0.0001 → 4, 0.005 → 3)."""
    digits = 0
    while digits < 12 and abs(round(increment, digits) - increment) > 1e-12 * max(1.0, increment):
        digits += 1
    return digits


def round_to_increment(value: float, increment: float) -> float:
    """``value`` on the control's input grid: the nearest whole multiple of ``increment`` (ties away from 0).

    The result is rounded to the increment's decimals so that it prints as the control holds it
    (``-412.519``, not ``-412.51900000000001``).
    """
    steps = value / increment
    whole = math.floor(abs(steps) + 0.5 + 1e-9) * (1.0 if steps >= 0 else -1.0)
    return round(whole * increment, decimals_of(increment)) + 0.0


def current_from_control(model: ProcessModel, values: Mapping[Component, float], control_unit: str) -> dict[str, float]:
    """Model register ID → current value in the model's unit, from the values the control holds."""
    return {
        rid: to_model(float(values[comp]), comp, model.unit, control_unit)
        for rid, comp in model_components(model).items()
    }
