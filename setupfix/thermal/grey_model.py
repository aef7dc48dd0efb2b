"""The Grey GMC(1,N) / GM(1,N) thermal-error estimator, calibrated by least squares, cuckoo search or PSO.

Abdulshahed, Longstaff & Fletcher (2017); the pure Grey functions are in :mod:`setupfix.thermal.grey`, the
conventions common to all estimators in :mod:`setupfix.thermal.estimator`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt
from scipy.optimize import lsq_linear

from setupfix.core.errors import Note
from setupfix.core.params import Constraint, Interval, Options
from setupfix.search import generator
from setupfix.thermal import grey
from setupfix.thermal.calibrate import SearchResult, cuckoo_search, particle_swarm
from setupfix.thermal.estimator import DEFAULT_SEED, SEED, ThermalModel, as_2d, check_shape

__all__ = ["GreyModel"]

Array = npt.NDArray[np.float64]


class GreyModel(ThermalModel):
    """GMC(1,N) (or classic GM(1,N)) of the thermal error on rises from the reference state.

    **Static limit of eq. (2).**  With the composite trapezoid (``form="trapezoid"``,
    Abdulshahed 2017 eq. (2)) the response is
    ``x̂1(k) = ½ Σ_j b_j x_j(k) + e^{-b1}·(…)``: once ``e^{-b1}`` is negligible — b1 of
    4–90 per sample on real logs, b1 = 5 in the paper's Table I — the prediction is the
    static regression ``½ Σ_j b_j x_j^{(0)}(k)`` after two or three samples, and b1, u and
    the initial value stop mattering.  Tien's form (``form="tien"``) weights every
    interval by ``e^{-b1/2}`` and has no such floor: at large b1 its response vanishes,
    so its calibration is driven to a b1 where the dynamics matter.

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
        "seed": SEED,
    }

    def __init__(
        self,
        *,
        calibration: str = "cs",
        kind: str = "gmc",
        form: str = "trapezoid",
        delay: int = 0,
        bound: float = 100.0,
        b1_min: float = 1e-6,
        population: int = 25,
        iterations: int = 100,
        pa: float = 0.25,
        seed: int = DEFAULT_SEED,
    ) -> None:
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

    def fit(
        self,
        T: npt.ArrayLike,
        y: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
    ) -> GreyModel:
        self._refuse_extras(ambient, speed, False)
        dT, dy = self._set_reference(as_2d(T), np.asarray(y, dtype=float))
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
                    res: SearchResult = cuckoo_search(
                        objective, lo, hi, n_nests=self.population, pa=self.pa, n_iter=self.iterations, rng=rng
                    )
                else:
                    res = particle_swarm(
                        objective, lo, hi, n_particles=self.population, n_iter=self.iterations, rng=rng
                    )
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

    def predict(
        self,
        T: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        y0: float | None = None,
        sensors_failed: bool = False,
    ) -> Array:
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
        check_shape("theta_", self.theta_, (S + (1 if self.kind == "gm1n" else 2),))
