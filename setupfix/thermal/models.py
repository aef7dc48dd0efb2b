"""Thin estimator classes over the pure functions: MRA, Grey GMC(1,N) and Kalman fusion.

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
from scipy.optimize import lsq_linear

from setupfix.errors import Note, NotFittedError, ParameterError
from setupfix.params import Constraint, Interval, Options, Predicate, ValidatedParams
from setupfix.thermal import grey
from setupfix.thermal.calibrate import SearchResult, cuckoo_search, genetic_algorithm, particle_swarm
from setupfix.thermal.kalman import FusionFilter, fuse
from setupfix.thermal.lumped import Gearbox, fit_lumped, heat_inputs, lumped_coefficients
from setupfix.thermal.mra import mra_fit, mra_predict, reference_state, rises_from
from setupfix.search import generator

__all__ = ["ThermalModel", "AnyThermalModel", "MRAModel", "GreyModel", "KalmanFusionModel", "KalmanStream",
           "NotFittedError", "rebase", "DEFAULT_SEED"]

Array = npt.NDArray[np.float64]
#: Seed of the stochastic calibrations when none is given (results are reproducible by default).
DEFAULT_SEED = 0
_SEED: list[Constraint] = [Interval(int, 0, 2**63 - 1)]


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

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None,
            speed: npt.ArrayLike | None = None) -> Self:
        """Fit on temperatures ``T`` (n, S) and the measured error ``y`` (n,); store the reference state."""
        raise NotImplementedError

    def predict(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None, speed: npt.ArrayLike | None = None,
                y0: float | None = None, sensors_failed: bool = False) -> Array:
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
        T2 = _as_2d(T)
        if T2.shape[1] != self.T_ref_.size:
            raise ParameterError(f"{self.name}: {T2.shape[1]} temperature inputs given, the model has "
                                 f"{self.T_ref_.size}")
        return rises_from(T2, self.T_ref_)

    def _refuse_extras(self, ambient: Any, speed: Any, sensors_failed: bool) -> None:
        if ambient is not None or speed is not None:
            raise ParameterError(f"{self.name}: ambient and speed are inputs of the kalman model only")
        if sensors_failed:
            raise ParameterError(f"{self.name}: sensors_failed applies to the kalman model only "
                                 "(the others have no model of the temperatures)")

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


def _as_2d(T: npt.ArrayLike) -> Array:
    T = np.asarray(T, dtype=float)
    return T.reshape(T.shape[0], -1)


def _shape(name: str, value: Any, shape: tuple[int, ...]) -> None:
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

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None,
            speed: npt.ArrayLike | None = None) -> MRAModel:
        self._refuse_extras(ambient, speed, False)
        dT, dy = self._set_reference(_as_2d(T), np.asarray(y, dtype=float))
        self.beta_ = mra_fit(dT, dy, intercept=self.intercept)
        return self

    def predict(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None, speed: npt.ArrayLike | None = None,
                y0: float | None = None, sensors_failed: bool = False) -> Array:
        """Predicted error (n,); ``y0`` re-bases it on a measured error at the first sample."""
        self._check_fitted()
        self._refuse_extras(ambient, speed, sensors_failed)
        return self._finish(self.y_ref_ + mra_predict(self.beta_, self._rises(T)), y0)

    def _check_shapes(self) -> None:
        super()._check_shapes()
        _shape("beta_", self.beta_, (self.T_ref_.size + int(self.intercept),))


class GreyModel(ThermalModel):
    """GMC(1,N) (or classic GM(1,N)) of the thermal error on rises from the reference state.

    **Static limit of eq. (2).**  With the composite trapezoid (``form="trapezoid"``,
    Abdulshahed 2017 eq. (2)) the response is
    ``x̂1(k) = ½ Σ_j b_j x_j(k) + e^{-b1}·(…)``: once ``e^{-b1}`` is negligible — b1 of
    4–90 per sample on real logs, b1 = 5 in the paper's Table I — the prediction is the
    static regression ``½ Σ_j b_j x_j^{(0)}(k)`` after two or three samples, and b1, u and
    the initial value stop mattering.  Tien's form (``form="tien"``) weights every
    interval by ``e^{-b1/2}`` and has no such floor: at large b1 its response vanishes,
    so its calibration is driven to a b1 where the dynamics matter
    (``bench/thermal_grey_forms.py`` compares both).

    Parameters
    ----------
    calibration : {"ls", "cs", "pso"}
        Least squares on the grey equation (b1 bounded positive, via
        :func:`scipy.optimize.lsq_linear`), or cuckoo search / PSO on the squared
        error of the convolution response (Abdulshahed 2017, §2.2).
    kind : {"gmc", "gm1n"}
    form : {"trapezoid", "tien"}
        Discretisation of the convolution, see :mod:`setupfix.thermal.grey`.
    delay : int
        Delay r in samples (eq. (1)).
    bound : float
        Search box ±bound of every coefficient (Table II: 100).
    b1_min : float
        Lower bound of the development coefficient.  b1 ≤ 0 makes ``e^{-b1 k}`` grow
        without limit, so the response diverges on any log longer than the training one.
    population, iterations : int
        Nests / particles and iterations (Table II: 25 and 100).
    pa : float
        Discovery probability of cuckoo search (0.25).
    seed : int
        Seed of the stochastic calibrations (default :data:`DEFAULT_SEED`).
    """

    dynamic = True
    _learned = ("theta_", "n_train_", "n_evaluations_", "train_rmse_")
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "calibration": [Options({"ls", "cs", "pso"})],
        "kind": [Options({"gmc", "gm1n"})],
        "form": [Options({"trapezoid", "tien"})],
        "delay": [Interval(int, 0, 10_000)],
        "bound": [Interval(float, 0, 1e6, closed="right")],
        "b1_min": [Interval(float, 0, None, closed="neither")],
        "population": [Interval(int, 2, 10_000)],
        "iterations": [Interval(int, 1, 100_000)],
        "pa": [Interval(float, 0, 1)],
        "seed": _SEED,
    }

    def __init__(self, *, calibration: str = "cs", kind: str = "gmc", form: str = "trapezoid", delay: int = 0,
                 bound: float = 100.0, b1_min: float = 1e-6, population: int = 25, iterations: int = 100,
                 pa: float = 0.25, seed: int = DEFAULT_SEED) -> None:
        self.calibration = calibration
        self.kind = kind
        self.form = form
        self.delay = delay
        self.bound = bound
        self.b1_min = b1_min
        self.population = population
        self.iterations = iterations
        self.pa = pa
        self.seed = seed

    @property
    def method(self) -> str:  # type: ignore[override]  # a property over the base class attribute
        return f"grey-{self.calibration}"

    def _response(self, theta: Array, y0: float, X1: Array) -> Array:
        if self.kind == "gm1n":
            return grey.gm1n_response(theta, y0, X1)
        return grey.gmc_response(theta, y0, X1, self.form)  # type: ignore[arg-type]  # form checked by validate_params

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None,
            speed: npt.ArrayLike | None = None) -> GreyModel:
        self._refuse_extras(ambient, speed, False)
        dT, dy = self._set_reference(_as_2d(T), np.asarray(y, dtype=float))
        X = grey.lag_drivers(dT, self.delay)
        if self.kind == "gm1n":
            B, Y = grey.gm1n_design(dy, X)
        else:
            B, Y = grey.gmc_design(dy, X)
        dim = B.shape[1]
        lo = np.full(dim, -float(self.bound))
        hi = np.full(dim, float(self.bound))
        lo[0] = min(self.b1_min, hi[0])
        X1 = grey.ago(X)
        y0 = float(dy[0])
        self.n_train_ = int(dy.size)
        self.fit_notes_: list[Note] = []
        if self.calibration == "ls":
            # Bounded linear least squares: the plain LS solution may have b1 <= 0.
            theta = lsq_linear(B, Y, bounds=(lo, hi)).x
            self.n_evaluations_ = 1
        else:
            def objective(pop: Array) -> Array:
                resid = grey.iago(self._response(pop, y0, X1)) - dy
                sse: Array = np.sum(resid[:, 1:] ** 2, axis=1)  # k = 1 is exact by construction
                return sse

            rng = generator(self.seed)
            with np.errstate(over="ignore", invalid="ignore"):
                if self.calibration == "cs":
                    res: SearchResult = cuckoo_search(objective, lo, hi, n_nests=self.population, pa=self.pa,
                                                      n_iter=self.iterations, rng=rng)
                else:
                    res = particle_swarm(objective, lo, hi, n_particles=self.population, n_iter=self.iterations,
                                         rng=rng)
            theta = res.x
            self.n_evaluations_ = res.n_evaluations
            self.history_ = res.history
        self.theta_ = np.asarray(theta, dtype=float)
        with np.errstate(over="ignore", invalid="ignore"):
            fitted = grey.iago(self._response(self.theta_, y0, X1))
        self.train_rmse_ = float(np.sqrt(np.mean((fitted - dy)[1:] ** 2)))
        if not np.isfinite(self.train_rmse_):
            self.fit_notes_.append(Note("grey model response is not finite on its training data", kind="thermal"))
        return self

    def predict(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None, speed: npt.ArrayLike | None = None,
                y0: float | None = None, sensors_failed: bool = False) -> Array:
        """Predicted error (n,), the response started from the static estimate at the first sample."""
        self._check_fitted()
        self._refuse_extras(ambient, speed, sensors_failed)
        dT = self._rises(T)
        if dT.shape[0] == 0:
            return np.zeros(0)
        warmup = 0
        if np.max(np.abs(dT[0])) > 1e-9 * (1.0 + float(np.max(np.abs(self.T_ref_)))):
            warmup = int(self.n_train_)
            ramp = np.linspace(0.0, 1.0, warmup, endpoint=False)[:, None] * dT[:1]
            dT = np.concatenate([ramp, dT])
        X = grey.lag_drivers(dT, self.delay)
        with np.errstate(over="ignore", invalid="ignore"):
            pred = self.y_ref_ + grey.iago(self._response(self.theta_, 0.0, grey.ago(X)))[warmup:]
        return self._finish(pred, y0)

    def _check_shapes(self) -> None:
        super()._check_shapes()
        S = self.T_ref_.size
        _shape("theta_", self.theta_, (S + (1 if self.kind == "gm1n" else 2),))


class KalmanFusionModel(ThermalModel):
    """Lumped-mass + Kalman fusion + regression on fused rises (Wang et al. 2017).

    Fitting follows §3.4 in two steps: the GA fits ``v1, v2 (, v3)`` of each sensor's
    lumped mass on F1 (eq. (12)); a second GA fits ``log10(N/R)`` of each sensor on
    F2 (eq. (13)), the regression β of eq. (11) being solved by least squares for
    every candidate.  The filter starts at the first readings of a log.

    **Without a spindle speed** (``speed=None`` at fit) the heat input C of eq. (5) is
    zero: each lumped mass only exchanges heat with the ambient, the noise ratio N/R is
    searched from 1 up (the readings weigh at least as much as a model that cannot
    see a heating), the filter smooths the readings, and ``uses_speed_`` is False (the
    pipeline flags it in every output).  ``sensors_failed`` is then refused: the lumped-mass model alone cannot
    follow a heating it has no input for.  **Without an ambient column** the ambient
    temperature is taken as constant at the median of the reference temperatures
    (``ambient_const_``).

    Parameters
    ----------
    gearbox_breaks, gearbox_ratios : sequence of float
        Optional reduction ratio of the spindle drive (see :class:`~setupfix.thermal.lumped.Gearbox`).
    jump : float
        Reading change (°C per sample) taken as a sensor failure at prediction time.
    pop_size, generations : int
        GA population and generations (both steps).
    p_crossover, p_mutation : float
        0.7 and 0.02 (§4).
    log10_q_bounds : (float, float)
        Search box of log10(N/R).
    seed : int
    """

    method = "kalman"
    dynamic = True
    _learned = ("A_", "B_", "v_", "q_", "beta_", "uses_speed_", "ambient_const_")
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "gearbox_breaks": [Predicate(lambda v: all(np.isfinite(b) and b > 0 for b in v), "positive speeds")],
        "gearbox_ratios": [Predicate(lambda v: len(v) >= 1 and all(np.isfinite(r) and r > 0 for r in v),
                                     "positive ratios")],
        "jump": [Interval(float, 0, None, closed="neither")],
        "pop_size": [Interval(int, 2, 10_000)],
        "generations": [Interval(int, 1, 100_000)],
        "p_crossover": [Interval(float, 0, 1)],
        "p_mutation": [Interval(float, 0, 1)],
        "log10_q_bounds": [Predicate(lambda v: len(v) == 2 and -30 <= v[0] < v[1] <= 30,
                                     "two numbers lo < hi in [-30, 30]")],
        "seed": _SEED,
    }

    def __init__(self, *, gearbox_breaks: tuple[float, ...] | list[float] = (),
                 gearbox_ratios: tuple[float, ...] | list[float] = (1.0,), jump: float = 2.0, pop_size: int = 40,
                 generations: int = 60, p_crossover: float = 0.7, p_mutation: float = 0.02,
                 log10_q_bounds: tuple[float, float] | list[float] = (-8.0, 2.0), seed: int = DEFAULT_SEED) -> None:
        self.gearbox_breaks = tuple(gearbox_breaks)
        self.gearbox_ratios = tuple(gearbox_ratios)
        self.jump = jump
        self.pop_size = pop_size
        self.generations = generations
        self.p_crossover = p_crossover
        self.p_mutation = p_mutation
        self.log10_q_bounds = tuple(log10_q_bounds)
        self.seed = seed

    def validate_params(self) -> None:
        super().validate_params()
        try:
            self.gearbox  # noqa: B018 - builds and checks the gearbox
        except ValueError as exc:
            raise ParameterError(f"KalmanFusionModel: {exc}") from None

    @property
    def gearbox(self) -> Gearbox:
        return Gearbox(self.gearbox_breaks, self.gearbox_ratios)

    def _heat_input(self, speed: Array) -> Array:
        """Heat input C per sensor and sample (S, n), eq. (5)."""
        _, _, C = lumped_coefficients(self.v_[:, 0], self.v_[:, 1], self.v_[:, 2], heat_inputs(speed, self.gearbox))
        return C

    def _drives(self, T: Array, ambient: npt.ArrayLike | None, speed: npt.ArrayLike | None) -> tuple[Array, Array]:
        n = T.shape[0]
        if (speed is not None) != bool(self.uses_speed_):
            raise ParameterError("kalman: the model was fitted " + ("with" if self.uses_speed_ else "without")
                                 + " a spindle speed; predict the same way")
        sp = np.zeros(n) if speed is None else np.asarray(speed, dtype=float)
        te = np.full(n, self.ambient_const_) if ambient is None else np.asarray(ambient, dtype=float)
        return te, sp

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None,
            speed: npt.ArrayLike | None = None) -> KalmanFusionModel:
        T = _as_2d(T)
        y = np.asarray(y, dtype=float)
        _, dy = self._set_reference(T, y)
        self.uses_speed_ = speed is not None
        self.ambient_const_ = float(np.median(self.T_ref_))
        te, sp = (np.asarray(ambient, dtype=float) if ambient is not None else np.full(len(y), self.ambient_const_),
                  np.zeros(len(y)) if speed is None else np.asarray(speed, dtype=float))
        rng = generator(self.seed)
        S = T.shape[1]
        v = np.zeros((S, 3))
        for i in range(S):  # step 1: lumped-mass parameters, eq. (12)
            params, _ = fit_lumped(T[:, i], te, sp, gearbox=self.gearbox, rng=rng, pop_size=self.pop_size,
                                   n_gen=self.generations, p_crossover=self.p_crossover, p_mutation=self.p_mutation)
            v[i] = params.v1, params.v2, params.v3
        self.v_ = v
        self.A_ = 1.0 / (1.0 + v[:, 0])
        self.B_ = v[:, 0] / (1.0 + v[:, 0])
        C = self._heat_input(sp)

        def objective(pop: Array) -> Array:  # step 2: noise ratios, eq. (13)
            fused, _ = fuse(T, te, self.A_, self.B_, C, 10.0 ** pop)  # (P, n, S)
            dT = fused - self.T_ref_
            out = np.empty(len(pop))
            for p in range(len(pop)):
                beta = mra_fit(dT[p], dy)
                r = dy - dT[p] @ beta
                out[p] = np.sqrt(np.sum(r * r) / max(len(dy) - 1, 1))
            return out

        lo = np.full(S, self.log10_q_bounds[0])
        hi = np.full(S, self.log10_q_bounds[1])
        if not self.uses_speed_:
            # No heat input: the lumped-mass prediction knows nothing of a heating, so the
            # filter must weigh the readings at least as much as the model (N/R >= 1).
            lo = np.minimum(np.maximum(lo, 0.0), hi)
        res = genetic_algorithm(objective, lo, hi, pop_size=self.pop_size, n_gen=self.generations,
                                p_crossover=self.p_crossover, p_mutation=self.p_mutation, rng=rng)
        self.q_ = 10.0 ** res.x
        fused, _ = fuse(T, te, self.A_, self.B_, C, self.q_)
        self.beta_ = mra_fit(fused - self.T_ref_, dy)
        return self

    def fused_temperatures(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None,
                           speed: npt.ArrayLike | None = None, sensors_failed: bool = False) -> tuple[Array, Array]:
        """Fused temperatures (n, S) and gains (n, S); ``sensors_failed`` forces gain 0 throughout."""
        self._check_fitted()
        T = _as_2d(T)
        if T.shape[1] != self.T_ref_.size:
            raise ParameterError(f"kalman: {T.shape[1]} temperature inputs given, the model has {self.T_ref_.size}")
        te, sp = self._drives(T, ambient, speed)
        C = self._heat_input(sp)
        if sensors_failed:
            if not self.uses_speed_:
                raise ParameterError("kalman: sensors_failed needs a model fitted with a spindle speed "
                                     "(without one the lumped masses have no heat input to follow)")
            x0 = np.where(np.isfinite(T[0]), T[0], te[0])
            return fuse(np.full_like(T, np.nan), te, self.A_, self.B_, C, self.q_, x0=x0)
        return fuse(T, te, self.A_, self.B_, C, self.q_, jump=self.jump)

    def predict(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike | None = None, speed: npt.ArrayLike | None = None,
                y0: float | None = None, sensors_failed: bool = False) -> Array:
        """Predicted error, eq. (10) on the fused rises from the reference state."""
        fused, _gains = self.fused_temperatures(T, ambient=ambient, speed=speed, sensors_failed=sensors_failed)
        return self._finish(self.y_ref_ + mra_predict(self.beta_, fused - self.T_ref_), y0)

    def stream(self) -> KalmanStream:
        """A streaming predictor: one call per sample, O(S) work."""
        self._check_fitted()
        return KalmanStream(self)

    def _check_shapes(self) -> None:
        super()._check_shapes()
        S = self.T_ref_.size
        for name, shape in (("A_", (S,)), ("B_", (S,)), ("q_", (S,)), ("beta_", (S,)), ("v_", (S, 3))):
            _shape(name, getattr(self, name), shape)
        self.uses_speed_ = bool(self.uses_speed_)


class KalmanStream:
    """Streaming thermal-error prediction of a fitted :class:`KalmanFusionModel`."""

    def __init__(self, model: KalmanFusionModel) -> None:
        self.model = model
        self.filter = FusionFilter(model.A_, model.B_, model.q_, jump=model.jump)

    def step(self, measured: npt.ArrayLike, ambient: float | None = None, speed: float | None = None) -> float:
        """Fuse one sample and return the predicted thermal error (relative to the reference state)."""
        m = self.model
        te, sp = m._drives(np.zeros((1, m.T_ref_.size)), None if ambient is None else [ambient],
                           None if speed is None else [speed])
        c = m._heat_input(sp)[:, 0]
        fused = self.filter.step(measured, float(te[0]), c)
        return float(m.y_ref_ + mra_predict(m.beta_, fused - m.T_ref_))


#: Any of the fitted thermal models (what the pipeline makes, saves and loads).
AnyThermalModel = MRAModel | GreyModel | KalmanFusionModel
