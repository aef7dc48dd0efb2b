"""The thermal methods by name: one registry used by the CLI, the pipeline and model files.

Each :class:`ThermalMethod` names an estimator class (:mod:`setupfix.thermal.estimator`,
:mod:`~.grey_model`, :mod:`~.kalman_model`) and the hyper-parameters its name fixes
(``grey-cs`` is a :class:`GreyModel` with ``calibration="cs"``).  :func:`make_model`
builds one and validates its parameters right after construction, before any data is
read; :func:`model_from_dict` rebuilds a saved one.  A new method is one :func:`register`
call.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from setupfix.core.errors import ParameterError
from setupfix.thermal.estimator import MRAModel, ThermalModel
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.kalman_model import KalmanFusionModel

__all__ = ["ThermalMethod", "register", "methods", "get_method", "make_model", "model_from_dict", "AnyThermalModel"]

#: Any of the fitted thermal models (what the pipeline makes, saves and loads).
AnyThermalModel = MRAModel | GreyModel | KalmanFusionModel


@dataclass(frozen=True)
class ThermalMethod:
    """A named thermal method.

    Attributes
    ----------
    name : str
        Registry name (``--method``).
    cls : type
        Estimator class.
    fixed : mapping
        Hyper-parameters the name fixes.
    stochastic : bool
        Calibrated by a seeded search (the seed is printed with the result).
    uses_drives : bool
        Takes ambient and spindle-speed columns (kalman).
    summary : str
        One line for ``--help``.
    """

    name: str
    cls: type[ThermalModel]
    fixed: Mapping[str, Any] = field(default_factory=dict)
    stochastic: bool = False
    uses_drives: bool = False
    summary: str = ""

    def make(self, **params: Any) -> ThermalModel:
        """A fresh, validated model; :class:`ParameterError` on an unknown or bad parameter."""
        clash = set(params) & set(self.fixed)
        if clash:
            raise ParameterError(f"thermal method {self.name!r} fixes {', '.join(sorted(clash))}")
        try:
            model = self.cls(**self.fixed, **params)
        except TypeError:
            known = sorted(set(self.cls().get_params()) - set(self.fixed))
            unknown = sorted(set(params) - set(known))
            raise ParameterError(
                f"thermal method {self.name!r} has no parameter {', '.join(unknown)}",
                hint=f"its parameters: {', '.join(known)}",
            ) from None
        model.validate_params()
        return model


_REGISTRY: dict[str, ThermalMethod] = {}


def register(method: ThermalMethod) -> ThermalMethod:
    """Add a method (a name registered twice is a programming error)."""
    if method.name in _REGISTRY:
        raise ValueError(f"thermal method {method.name!r} registered twice")
    _REGISTRY[method.name] = method
    return method


def methods() -> tuple[str, ...]:
    """Registered method names, in registration order."""
    return tuple(_REGISTRY)


def get_method(name: str) -> ThermalMethod:
    """The method called ``name``; :class:`ParameterError` naming the known ones otherwise."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown thermal method {name!r}", hint=f"choose one of {', '.join(_REGISTRY)}") from None


def make_model(name: str, **params: Any) -> ThermalModel:
    """A fresh validated model of the method ``name``."""
    return get_method(name).make(**params)


def model_from_dict(data: Mapping[str, Any]) -> ThermalModel:
    """Rebuild a fitted model from its ``to_dict`` form.

    Raises
    ------
    ParameterError
        Unknown method or bad hyper-parameter.
    KeyError, TypeError, ValueError
        Missing, mistyped or inconsistent learned values (the caller names the file).
    """
    spec = get_method(str(data["method"]))
    params = {k: v for k, v in dict(data.get("params", {})).items() if k not in spec.fixed}
    return spec.cls.from_dict({"params": params, "learned": data["learned"]}, **spec.fixed)


register(ThermalMethod("mra", MRAModel, summary="multivariate regression on temperature rises (Wang 2017 eq. 16)"))
register(
    ThermalMethod(
        "grey-ls", GreyModel, {"calibration": "ls"}, summary="Grey GMC(1,N), bounded least squares on the grey equation"
    )
)
register(
    ThermalMethod(
        "grey-cs",
        GreyModel,
        {"calibration": "cs"},
        stochastic=True,
        summary="Grey GMC(1,N) calibrated by cuckoo search (Abdulshahed 2017)",
    )
)
register(
    ThermalMethod(
        "grey-pso",
        GreyModel,
        {"calibration": "pso"},
        stochastic=True,
        summary="Grey GMC(1,N) calibrated by PSO (Abdulshahed 2017)",
    )
)
register(
    ThermalMethod(
        "kalman",
        KalmanFusionModel,
        stochastic=True,
        uses_drives=True,
        summary="lumped-mass + Kalman fusion + regression (Wang 2017)",
    )
)
