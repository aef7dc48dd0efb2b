"""The lumped-mass + Kalman fusion thermal-error estimator and its streaming predictor (Wang et al. 2017).

The scalar filter is in :mod:`setupfix.thermal.kalman`, the lumped-mass model in :mod:`setupfix.thermal.lumped`,
the conventions common to all estimators in :mod:`setupfix.thermal.estimator`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ParameterError
from setupfix.core.params import Constraint, Interval, Predicate
from setupfix.search import generator
from setupfix.thermal.calibrate import genetic_algorithm
from setupfix.thermal.estimator import DEFAULT_SEED, SEED, ThermalModel, as_2d, check_shape
from setupfix.thermal.kalman import FusionFilter, fuse
from setupfix.thermal.lumped import Gearbox, fit_lumped, heat_inputs, lumped_coefficients
from setupfix.thermal.mra import mra_fit, mra_predict

__all__ = ["KalmanFusionModel", "KalmanStream"]

Array = npt.NDArray[np.float64]


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
        "gearbox_ratios": [
            Predicate(lambda v: len(v) >= 1 and all(np.isfinite(r) and r > 0 for r in v), "positive ratios")
        ],
        "jump": [Interval(float, 0, None, closed="neither")],
        "pop_size": [Interval(int, 2, 10_000)],
        "generations": [Interval(int, 1, 100_000)],
        "p_crossover": [Interval(float, 0, 1)],
        "p_mutation": [Interval(float, 0, 1)],
        "log10_q_bounds": [
            Predicate(lambda v: len(v) == 2 and -30 <= v[0] < v[1] <= 30, "two numbers lo < hi in [-30, 30]")
        ],
        "seed": SEED,
    }

    def __init__(
        self,
        *,
        gearbox_breaks: tuple[float, ...] | list[float] = (),
        gearbox_ratios: tuple[float, ...] | list[float] = (1.0,),
        jump: float = 2.0,
        pop_size: int = 40,
        generations: int = 60,
        p_crossover: float = 0.7,
        p_mutation: float = 0.02,
        log10_q_bounds: tuple[float, float] | list[float] = (-8.0, 2.0),
        seed: int = DEFAULT_SEED,
    ) -> None:
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
            raise ParameterError(
                "kalman: the model was fitted "
                + ("with" if self.uses_speed_ else "without")
                + " a spindle speed; predict the same way"
            )
        sp = np.zeros(n) if speed is None else np.asarray(speed, dtype=float)
        te = np.full(n, self.ambient_const_) if ambient is None else np.asarray(ambient, dtype=float)
        return te, sp

    def fit(
        self,
        T: npt.ArrayLike,
        y: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
    ) -> KalmanFusionModel:
        T = as_2d(T)
        y = np.asarray(y, dtype=float)
        _, dy = self._set_reference(T, y)
        self.uses_speed_ = speed is not None
        self.ambient_const_ = float(np.median(self.T_ref_))
        te, sp = (
            np.asarray(ambient, dtype=float) if ambient is not None else np.full(len(y), self.ambient_const_),
            np.zeros(len(y)) if speed is None else np.asarray(speed, dtype=float),
        )
        rng = generator(self.seed)
        S = T.shape[1]
        v = np.zeros((S, 3))
        for i in range(S):  # step 1: lumped-mass parameters, eq. (12)
            params, _ = fit_lumped(
                T[:, i],
                te,
                sp,
                gearbox=self.gearbox,
                rng=rng,
                pop_size=self.pop_size,
                n_gen=self.generations,
                p_crossover=self.p_crossover,
                p_mutation=self.p_mutation,
            )
            v[i] = params.v1, params.v2, params.v3
        self.v_ = v
        self.A_ = 1.0 / (1.0 + v[:, 0])
        self.B_ = v[:, 0] / (1.0 + v[:, 0])
        C = self._heat_input(sp)

        def objective(pop: Array) -> Array:  # step 2: noise ratios, eq. (13)
            fused, _ = fuse(T, te, self.A_, self.B_, C, 10.0**pop)  # (P, n, S)
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
        res = genetic_algorithm(
            objective,
            lo,
            hi,
            pop_size=self.pop_size,
            n_gen=self.generations,
            p_crossover=self.p_crossover,
            p_mutation=self.p_mutation,
            rng=rng,
        )
        self.q_ = 10.0**res.x
        fused, _ = fuse(T, te, self.A_, self.B_, C, self.q_)
        self.beta_ = mra_fit(fused - self.T_ref_, dy)
        return self

    def fused_temperatures(
        self,
        T: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        sensors_failed: bool = False,
    ) -> tuple[Array, Array]:
        """Fused temperatures (n, S) and gains (n, S); ``sensors_failed`` forces gain 0 throughout."""
        self._check_fitted()
        T = as_2d(T)
        if T.shape[1] != self.T_ref_.size:
            raise ParameterError(f"kalman: {T.shape[1]} temperature inputs given, the model has {self.T_ref_.size}")
        te, sp = self._drives(T, ambient, speed)
        C = self._heat_input(sp)
        if sensors_failed:
            if not self.uses_speed_:
                raise ParameterError(
                    "kalman: sensors_failed needs a model fitted with a spindle speed "
                    "(without one the lumped masses have no heat input to follow)"
                )
            x0 = np.where(np.isfinite(T[0]), T[0], te[0])
            return fuse(np.full_like(T, np.nan), te, self.A_, self.B_, C, self.q_, x0=x0)
        return fuse(T, te, self.A_, self.B_, C, self.q_, jump=self.jump)

    def predict(
        self,
        T: npt.ArrayLike,
        *,
        ambient: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        y0: float | None = None,
        sensors_failed: bool = False,
    ) -> Array:
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
            check_shape(name, getattr(self, name), shape)
        self.uses_speed_ = bool(self.uses_speed_)


class KalmanStream:
    """Streaming thermal-error prediction of a fitted :class:`KalmanFusionModel`."""

    def __init__(self, model: KalmanFusionModel) -> None:
        self.model = model
        self.filter = FusionFilter(model.A_, model.B_, model.q_, jump=model.jump)

    def step(self, measured: npt.ArrayLike, ambient: float | None = None, speed: float | None = None) -> float:
        """Fuse one sample and return the predicted thermal error (relative to the reference state)."""
        m = self.model
        te, sp = m._drives(
            np.zeros((1, m.T_ref_.size)), None if ambient is None else [ambient], None if speed is None else [speed]
        )
        c = m._heat_input(sp)[:, 0]
        fused = self.filter.step(measured, float(te[0]), c)
        return float(m.y_ref_ + mra_predict(m.beta_, fused - m.T_ref_))
