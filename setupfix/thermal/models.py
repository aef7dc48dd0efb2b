"""Thin estimator classes over the pure functions: MRA, Grey GMC(1,N) and Kalman fusion.

sklearn conventions: hyper-parameters are keyword-only ``__init__`` arguments,
``fit`` returns ``self``, learned attributes end in ``_``, ``predict`` refuses an
unfitted model, randomness only through ``seed``.  Inputs are arrays:

* ``T`` — temperatures, shape (n, S), °C (or rises, K);
* ``y`` — measured thermal error, shape (n,), any length unit;
* ``ambient``, ``speed`` — shape (n,), only for :class:`KalmanFusionModel`.

Every model works on temperature rises from the first sample of each log (Wang 2017
eq. (10) uses ΔT), so a log is assumed to start from the state its error is measured
from (usually a cold start).  ``to_dict`` / ``from_dict`` give the JSON form used by
:mod:`setupfix.thermal.persist`.
"""

from __future__ import annotations

import warnings
from typing import Any, ClassVar, Self

import numpy as np
import numpy.typing as npt
from scipy.optimize import lsq_linear

from setupfix.errors import ConvergenceWarning, NotFittedError
from setupfix.thermal import grey
from setupfix.thermal.calibrate import SearchResult, cuckoo_search, genetic_algorithm, particle_swarm
from setupfix.thermal.kalman import FusionFilter, fuse
from setupfix.thermal.lumped import Gearbox, fit_lumped, heat_inputs, lumped_coefficients
from setupfix.thermal.mra import mra_fit, mra_predict, rises

__all__ = ["ThermalModel", "AnyThermalModel", "MRAModel", "GreyModel", "KalmanFusionModel", "NotFittedError"]

Array = npt.NDArray[np.float64]


class ThermalModel:
    """Common base: parameter access and the fitted check."""

    method: ClassVar[str] = ""
    _learned: ClassVar[tuple[str, ...]] = ()

    def get_params(self) -> dict[str, Any]:
        """Hyper-parameters as given to ``__init__``."""
        return {k: v for k, v in vars(self).items() if not k.endswith("_") and not k.startswith("_")}

    def _check_fitted(self) -> None:
        if not all(hasattr(self, name) for name in self._learned):
            raise NotFittedError(f"the {self.method} model is not fitted", hint="call fit() or load a saved model")

    def to_dict(self) -> dict[str, Any]:
        self._check_fitted()
        learned = {}
        for name in self._learned:
            value = getattr(self, name)
            learned[name] = value.tolist() if isinstance(value, np.ndarray) else value
        return {"method": self.method, "params": _jsonable(self.get_params()), "learned": learned}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Self:
        model = cls(**data.get("params", {}))
        for name in cls._learned:
            value = data["learned"][name]
            setattr(model, name, np.asarray(value, dtype=float) if isinstance(value, list) else value)
        return model


def _jsonable(params: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, Gearbox):
            v = {"breaks": list(v.breaks), "ratios": list(v.ratios)}
        elif isinstance(v, tuple):
            v = list(v)
        out[k] = v
    return out


def _as_2d(T: npt.ArrayLike) -> Array:
    T = np.asarray(T, dtype=float)
    return T.reshape(T.shape[0], -1)


class MRAModel(ThermalModel):
    """Multivariate regression on measured rises, Wang (2017) eq. (16) — the baseline.

    Parameters
    ----------
    intercept : bool
        Add a constant term (the paper has none).
    """

    method = "mra"
    _learned = ("beta_",)

    def __init__(self, *, intercept: bool = False) -> None:
        self.intercept = intercept

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike) -> MRAModel:
        self.beta_ = mra_fit(rises(_as_2d(T)), y, intercept=self.intercept)
        return self

    def predict(self, T: npt.ArrayLike, **_: Any) -> Array:
        self._check_fitted()
        return mra_predict(self.beta_, rises(_as_2d(T)))


class GreyModel(ThermalModel):
    """GMC(1,N) (or classic GM(1,N)) of the thermal error on temperature rises.

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
        without limit, so the response diverges on any log longer than the training
        one (notes §4.3: RMSE 4·10¹ µm to 10⁷ µm on gooddash with an unconstrained LS).
    population, iterations : int
        Nests / particles and iterations (Table II: 25 and 100).
    pa : float
        Discovery probability of cuckoo search (0.25).
    seed : int, optional
    """

    _learned = ("theta_", "n_evaluations_", "train_rmse_")

    def __init__(self, *, calibration: str = "cs", kind: str = "gmc", form: str = "trapezoid", delay: int = 0,
                 bound: float = 100.0, b1_min: float = 1e-6, population: int = 25, iterations: int = 100,
                 pa: float = 0.25, seed: int | None = None) -> None:
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
    def method(self) -> str:  # type: ignore[override]
        return f"grey-{self.calibration}"

    def _response(self, theta: Array, y0: float, X1: Array) -> Array:
        if self.kind == "gm1n":
            return grey.gm1n_response(theta, y0, X1)
        return grey.gmc_response(theta, y0, X1, self.form)  # type: ignore[arg-type]

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike) -> GreyModel:
        X = grey.lag_drivers(rises(_as_2d(T)), self.delay)
        y = np.asarray(y, dtype=float)
        if self.kind == "gmc":
            B, Y = grey.gmc_design(y, X)
        elif self.kind == "gm1n":
            B, Y = grey.gm1n_design(y, X)
        else:
            raise ValueError(f"unknown grey model kind {self.kind!r}")
        dim = B.shape[1]
        lo = np.full(dim, -float(self.bound))
        hi = np.full(dim, float(self.bound))
        lo[0] = self.b1_min
        X1 = grey.ago(X)
        y0 = float(y[0])
        if self.calibration == "ls":
            # Bounded linear least squares: the plain LS solution may have b1 <= 0.
            theta = lsq_linear(B, Y, bounds=(lo, hi)).x
            self.n_evaluations_ = 1
        elif self.calibration in ("cs", "pso"):
            def objective(pop: Array) -> Array:
                resid = grey.iago(self._response(pop, y0, X1)) - y
                return np.sum(resid[:, 1:] ** 2, axis=1)  # k = 1 is exact by construction

            rng = np.random.default_rng(self.seed)
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
        else:
            raise ValueError(f"unknown calibration {self.calibration!r}")
        self.theta_ = np.asarray(theta, dtype=float)
        fitted = grey.iago(self._response(self.theta_, y0, X1))
        self.train_rmse_ = float(np.sqrt(np.mean((fitted - y)[1:] ** 2)))
        if not np.isfinite(self.train_rmse_):
            warnings.warn("grey model response is not finite on its training data", ConvergenceWarning, stacklevel=2)
        return self

    def predict(self, T: npt.ArrayLike, *, y0: float = 0.0, **_: Any) -> Array:
        """Predicted error for a log starting from target value ``y0`` (0: cold start)."""
        self._check_fitted()
        X = grey.lag_drivers(rises(_as_2d(T)), self.delay)
        with np.errstate(over="ignore", invalid="ignore"):
            return grey.iago(self._response(self.theta_, float(y0), grey.ago(X)))


class KalmanFusionModel(ThermalModel):
    """Lumped-mass + Kalman fusion + regression on fused rises (Wang et al. 2017).

    Fitting follows §3.4 in two steps: the GA fits ``v1, v2 (, v3)`` of each sensor's
    lumped mass on F1 (eq. (12)); a second GA fits ``log10(N/R)`` of each sensor on
    F2 (eq. (13)), the regression β of eq. (11) being solved by least squares for
    every candidate.

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
    seed : int, optional
    """

    method = "kalman"
    _learned = ("A_", "B_", "v_", "q_", "beta_")

    def __init__(self, *, gearbox_breaks: tuple[float, ...] | list[float] = (),
                 gearbox_ratios: tuple[float, ...] | list[float] = (1.0,), jump: float = 2.0, pop_size: int = 40,
                 generations: int = 60, p_crossover: float = 0.7, p_mutation: float = 0.02,
                 log10_q_bounds: tuple[float, float] | list[float] = (-8.0, 2.0), seed: int | None = None) -> None:
        self.gearbox_breaks = tuple(gearbox_breaks)
        self.gearbox_ratios = tuple(gearbox_ratios)
        self.jump = jump
        self.pop_size = pop_size
        self.generations = generations
        self.p_crossover = p_crossover
        self.p_mutation = p_mutation
        self.log10_q_bounds = tuple(log10_q_bounds)
        self.seed = seed

    @property
    def gearbox(self) -> Gearbox:
        return Gearbox(self.gearbox_breaks, self.gearbox_ratios)

    def _inputs(self, speed: npt.ArrayLike, S: int) -> Array:
        """Heat input C per sensor and sample, shape (S, n)."""
        heat = heat_inputs(speed, self.gearbox)
        _, _, C = lumped_coefficients(self.v_[:, 0], self.v_[:, 1], self.v_[:, 2], heat)
        return C

    def fit(self, T: npt.ArrayLike, y: npt.ArrayLike, *, ambient: npt.ArrayLike, speed: npt.ArrayLike) -> KalmanFusionModel:
        T = _as_2d(T)
        y = np.asarray(y, dtype=float)
        te = np.asarray(ambient, dtype=float)
        rng = np.random.default_rng(self.seed)
        S = T.shape[1]
        v = np.zeros((S, 3))
        for i in range(S):  # step 1: lumped-mass parameters, eq. (12)
            params, _ = fit_lumped(T[:, i], te, speed, gearbox=self.gearbox, rng=rng, pop_size=self.pop_size,
                                   n_gen=self.generations, p_crossover=self.p_crossover, p_mutation=self.p_mutation)
            v[i] = params.v1, params.v2, params.v3
        self.v_ = v
        self.A_ = 1.0 / (1.0 + v[:, 0])
        self.B_ = v[:, 0] / (1.0 + v[:, 0])
        C = self._inputs(speed, S)

        def objective(pop: Array) -> Array:  # step 2: noise ratios, eq. (13)
            fused, _ = fuse(T, te, self.A_, self.B_, C, 10.0 ** pop)  # (P, n, S)
            dT = rises(fused)
            out = np.empty(len(pop))
            for p in range(len(pop)):
                beta = mra_fit(dT[p], y)
                r = y - dT[p] @ beta
                out[p] = np.sqrt(np.sum(r * r) / max(len(y) - 1, 1))
            return out

        lo = np.full(S, self.log10_q_bounds[0])
        hi = np.full(S, self.log10_q_bounds[1])
        res = genetic_algorithm(objective, lo, hi, pop_size=self.pop_size, n_gen=self.generations,
                                p_crossover=self.p_crossover, p_mutation=self.p_mutation, rng=rng)
        self.q_ = 10.0 ** res.x
        fused, _ = fuse(T, te, self.A_, self.B_, C, self.q_)
        self.beta_ = mra_fit(rises(fused), y)
        return self

    def fused_temperatures(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike, speed: npt.ArrayLike,
                           sensors_failed: bool = False) -> tuple[Array, Array]:
        """Fused temperatures (n, S) and gains (n, S); ``sensors_failed`` forces gain 0 throughout."""
        self._check_fitted()
        T = _as_2d(T)
        C = self._inputs(speed, T.shape[1])
        te = np.asarray(ambient, dtype=float)
        if sensors_failed:
            x0 = np.where(np.isfinite(T[0]), T[0], te[0])
            T = np.full_like(T, np.nan)
            return fuse(T, te, self.A_, self.B_, C, self.q_, x0=x0)
        return fuse(T, te, self.A_, self.B_, C, self.q_, jump=self.jump)

    def predict(self, T: npt.ArrayLike, *, ambient: npt.ArrayLike, speed: npt.ArrayLike,
                sensors_failed: bool = False, **_: Any) -> Array:
        """Predicted error, eq. (10) on the fused rises."""
        fused, _gains = self.fused_temperatures(T, ambient=ambient, speed=speed, sensors_failed=sensors_failed)
        return mra_predict(self.beta_, rises(fused))

    def stream(self) -> KalmanStream:
        """A streaming predictor: one call per sample, O(S) work."""
        self._check_fitted()
        return KalmanStream(self)


class KalmanStream:
    """Streaming thermal-error prediction of a fitted :class:`KalmanFusionModel`."""

    def __init__(self, model: KalmanFusionModel) -> None:
        self.model = model
        self.filter = FusionFilter(model.A_, model.B_, model.q_, jump=model.jump)
        self._start: Array | None = None

    def step(self, measured: npt.ArrayLike, ambient: float, speed: float) -> float:
        """Fuse one sample and return the predicted thermal error."""
        m = self.model
        heat = heat_inputs(np.array([speed]), m.gearbox)[0]
        c = (m.v_[:, 1] * heat[0] + m.v_[:, 2] * heat[1]) / (1.0 + m.v_[:, 0])
        fused = self.filter.step(measured, ambient, c)
        if self._start is None:
            self._start = fused.copy()
        return float(mra_predict(m.beta_, fused - self._start))


#: Any of the fitted thermal models (what the pipeline makes, saves and loads).
AnyThermalModel = MRAModel | GreyModel | KalmanFusionModel
