"""The estimator base class of the thermal models, :func:`rebase` and the MRA baseline.

The estimators are thin classes over the pure functions: MRA here, Grey GMC(1,N) in
:mod:`setupfix.thermal.grey_model`, Kalman fusion in :mod:`setupfix.thermal.kalman_model`.

sklearn conventions: hyper-parameters are keyword-only ``__init__`` arguments declared
in ``_parameter_constraints`` (checked by ``validate_params()``, which the registry
:mod:`setupfix.thermal.registry` calls right after construction), ``fit`` returns
``self``, learned attributes end in ``_``, ``predict`` refuses an unfitted model,
randomness only through ``seed``.  Every model has the same signatures::

    fit(T, y, *, ambient=None, speed=None) -> self
    predict(T, *, ambient=None, speed=None, y0=None, sensors_failed=False) -> (n,)

* ``T`` — temperatures, shape (n, S), °C (or rises, K);
* ``y`` — measured thermal error, shape (n,), the target's unit;
* ``ambient``, ``speed`` — shape (n,), used by :class:`KalmanFusionModel` only (the
  others refuse them rather than ignore them).

**Reference state.**  Fitting stores the reference temperatures ``T_ref_`` (the first
training sample; the first finite reading of each sensor) and the error at that state
``y_ref_``.  Prediction is relative to them: ``ŷ = y_ref + f(T − T_ref)``, so a log may
start anywhere (a warm machine, the continuation of the training log) and is
predicted as if it continued the training run (Wang 2017 eq. (10) uses rises ΔT; here
they are rises from the stored reference, not from the log's first sample).
``y0`` re-bases a prediction on a measured error at the first sample: the whole
prediction is shifted so that ``ŷ[0] = y0`` (:func:`rebase`).

**Dynamic models start from the measured temperatures**; they do not replay history
the log does not contain.  The Kalman fusion starts its filter at the first readings
(Wang 2017 §3.3).  The Grey response is a convolution over the accumulated drivers
(AGO), which has no state a log could start from: a log that starts at the reference
state gets the response of the fit; a log that starts elsewhere is preceded by a
warm-up in which the temperatures rise linearly from the reference state to its first
sample over as many samples as the training log had (the machine is taken to have
warmed up as it did in training); the warm-up is then dropped.
"""

from __future__ import annotations

from typing import Any, ClassVar, Self

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import NotFittedError, ParameterError
from setupfix.core.params import Constraint, Interval, ValidatedParams
from setupfix.thermal.mra import mra_fit, mra_predict, reference_state, rises_from

__all__ = ["ThermalModel", "MRAModel", "rebase", "DEFAULT_SEED"]

Array = npt.NDArray[np.float64]
#: Seed of the stochastic calibrations when none is given (results are reproducible by default).
DEFAULT_SEED = 0
SEED: list[Constraint] = [Interval(int, 0, 2**63 - 1)]


def rebase(predicted: npt.ArrayLike, index: int, error: float) -> Array:
    """Shift a predicted error series so that it equals a measured ``error`` at sample ``index``.

    ``ŷ'(k) = ŷ(k) + (error − ŷ(index))`` — the anchor of ``--anchor TIME=ERROR``: the
    model keeps its shape, a measured error fixes its level.

    Parameters
    ----------
    predicted : array_like, shape (n,)
    index : int
        Sample of the measured error, 0 ≤ index < n.
    error : float
        Measured error there, the target's unit.

    Returns
    -------
    ndarray, shape (n,)
    """
    p = np.asarray(predicted, dtype=np.float64)
    return p + (float(error) - float(p[index]))


class ThermalModel(ValidatedParams):
    """Common base: parameter access, the reference state, JSON form and the fitted check."""

    method: ClassVar[str] = ""
    #: True for models whose prediction depends on the samples before (Grey, Kalman).
    dynamic: ClassVar[bool] = False
    _learned: ClassVar[tuple[str, ...]] = ()
    _common_learned: ClassVar[tuple[str, ...]] = ("T_ref_", "y_ref_")
    T_ref_: Array
    y_ref_: float

    @property
    def name(self) -> str:
        """Registry name of this model (``grey-cs`` for a cuckoo-search Grey model)."""
        return self.method

    def get_params(self) -> dict[str, Any]:
        """Hyper-parameters as given to ``__init__``."""
        return {k: v for k, v in vars(self).items() if not k.endswith("_") and not k.startswith("_")}

    def fit(
        self,
        T: npt.ArrayLike,
        y: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
    ) -> Self:
        """Fit on temperatures ``T`` (n, S) and the measured error ``y`` (n,); store the reference state."""
        raise NotImplementedError

    def predict(
        self,
        T: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        y0: float | None = None,
        sensors_failed: bool = False,
    ) -> Array:
        """Predicted error (n,) relative to the reference state; ``y0`` re-bases it at the first sample."""
        raise NotImplementedError

    def _check_fitted(self) -> None:
        if not all(hasattr(self, name) for name in self._learned + self._common_learned):
            raise NotFittedError(f"the {self.name} model is not fitted", hint="call fit() or load a saved model")

    @property
    def n_inputs(self) -> int:
        self._check_fitted()
        return int(self.T_ref_.size)

    def _set_reference(self, T: Array, y: Array) -> tuple[Array, Array]:
        """Store the reference state; return rises from it and the error relative to it."""
        self.T_ref_ = reference_state(T)
        self.y_ref_ = float(y[0])
        return rises_from(T, self.T_ref_), y - self.y_ref_

    def _rises(self, T: npt.ArrayLike) -> Array:
        T2 = as_2d(T)
        if T2.shape[1] != self.T_ref_.size:
            raise ParameterError(
                f"{self.name}: {T2.shape[1]} temperature inputs given, the model has {self.T_ref_.size}"
            )
        return rises_from(T2, self.T_ref_)

    def _refuse_extras(self, ambient: Any, speed: Any, sensors_failed: bool) -> None:
        if ambient is not None or speed is not None:
            raise ParameterError(f"{self.name}: ambient and speed are inputs of the kalman model only")
        if sensors_failed:
            raise ParameterError(
                f"{self.name}: sensors_failed applies to the kalman model only "
                "(the others have no model of the temperatures)"
            )

    @staticmethod
    def _finish(pred: Array, y0: float | None) -> Array:
        return pred if y0 is None or pred.size == 0 else rebase(pred, 0, y0)

    def to_dict(self) -> dict[str, Any]:
        self._check_fitted()
        learned: dict[str, Any] = {}
        for name in self._learned + self._common_learned:
            value = getattr(self, name)
            learned[name] = value.tolist() if isinstance(value, np.ndarray) else value
        return {"method": self.name, "params": _jsonable(self.get_params()), "learned": learned}

    @classmethod
    def from_dict(cls, data: dict[str, Any], **fixed: Any) -> Self:
        """Rebuild from :meth:`to_dict` (KeyError, TypeError or ValueError on bad content)."""
        params = dict(data.get("params", {}))
        params.update(fixed)
        model = cls(**params)
        model.validate_params()
        for name in cls._learned + cls._common_learned:
            value = data["learned"][name]
            if isinstance(value, list):
                value = np.asarray(value, dtype=float)
            elif isinstance(value, bool):
                pass
            elif not isinstance(value, (int, float)):
                raise TypeError(f"learned {name!r} must be a number or a list of numbers")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"learned {name!r} is not finite")
            setattr(model, name, value)
        model._check_shapes()
        return model

    def _check_shapes(self) -> None:
        """Raise ValueError when the learned arrays do not fit together (a corrupt file)."""
        if np.ndim(self.T_ref_) != 1 or self.T_ref_.size == 0:
            raise ValueError("learned 'T_ref_' must be a non-empty list")


def _jsonable(params: dict[str, Any]) -> dict[str, Any]:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in params.items()}


def as_2d(T: npt.ArrayLike) -> Array:
    T = np.asarray(T, dtype=float)
    return T.reshape(T.shape[0], -1)


def check_shape(name: str, value: Any, shape: tuple[int, ...]) -> None:
    if np.shape(value) != shape:
        raise ValueError(f"learned {name!r} has shape {np.shape(value)}, expected {shape}")


class MRAModel(ThermalModel):
    """Multivariate regression on rises from the reference state, Wang (2017) eq. (16) — the baseline.

    ``ŷ = y_ref + β·(T − T_ref)`` (+ β₀ with ``intercept``).

    Parameters
    ----------
    intercept : bool
        Add a constant term (the paper has none).
    """

    method = "mra"
    _learned = ("beta_",)
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {"intercept": [bool]}

    def __init__(self, *, intercept: bool = False) -> None:
        self.intercept = intercept

    def fit(
        self,
        T: npt.ArrayLike,
        y: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
    ) -> MRAModel:
        self._refuse_extras(ambient, speed, False)
        dT, dy = self._set_reference(as_2d(T), np.asarray(y, dtype=float))
        self.beta_ = mra_fit(dT, dy, intercept=self.intercept)
        return self

    def predict(
        self,
        T: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        y0: float | None = None,
        sensors_failed: bool = False,
    ) -> Array:
        """Predicted error (n,); ``y0`` re-bases it on a measured error at the first sample."""
        self._check_fitted()
        self._refuse_extras(ambient, speed, sensors_failed)
        return self._finish(self.y_ref_ + mra_predict(self.beta_, self._rises(T)), y0)

    def _check_shapes(self) -> None:
        super()._check_shapes()
        check_shape("beta_", self.beta_, (self.T_ref_.size + int(self.intercept),))
