"""Modified lumped-mass temperature model (Wang et al. 2017, eqs. (1)–(4)) and its GA fit.

One lumped mass per temperature sensor, heated by the spindle (heat proportional to
the speed n, eq. (3)) and exchanging heat with the environment::

    (M + v1) T^j = M T^{j-1} + v1 T_e^j + v2 n^j + v3 n^j / f(n^j)          (eq. 4)

with ``M = m c / Δt``.  Only the ratios ``v/M`` can be identified from temperatures,
so ``M`` is fixed to 1 and ``v1, v2, v3`` are in units of ``m c / Δt``.  The motor
term uses the reduction ratio ``f(n)`` of a gearbox (the paper's machine switches
ratio at 750 rpm); without a gearbox ``f = 1`` and ``v3`` is dropped because it
would only duplicate ``v2``.  Written in the filter's form (eq. (5))::

    T^j = A T^{j-1} + B T_e^j + C^j,   A = M/(M+v1),  B = v1/(M+v1) = 1 - A,
    C^j = (v2 n^j + v3 n^j / f(n^j)) / (M + v1).

Speeds enter in 1000 rpm so that the coefficients stay of order one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.optimize import lsq_linear
from scipy.signal import lfilter

from setupfix.thermal.calibrate import SearchResult, genetic_algorithm
from setupfix.thermal.metrics import rmsv

__all__ = [
    "Gearbox",
    "LumpedParams",
    "heat_inputs",
    "lumped_coefficients",
    "lumped_simulate",
    "lumped_equation_error",
    "fit_lumped",
]

Array = npt.NDArray[np.float64]
SPEED_UNIT = 1000.0  #: rpm per model speed unit


@dataclass(frozen=True)
class Gearbox:
    """Reduction ratio as a step function of speed: ``ratios[i]`` applies below ``breaks[i]``.

    ``Gearbox(breaks=(750.0,), ratios=(1102/2263, 464/3796))`` is the machine of Wang
    et al. (2017), §2.  The empty gearbox (default) has ratio 1 everywhere.
    """

    breaks: tuple[float, ...] = ()
    ratios: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        if len(self.ratios) != len(self.breaks) + 1 or any(r <= 0 for r in self.ratios):
            raise ValueError("a gearbox needs one positive ratio more than breaks")

    @property
    def trivial(self) -> bool:
        return not self.breaks and self.ratios == (1.0,)

    def ratio(self, speed: npt.ArrayLike) -> Array:
        """Reduction ratio f(n), shape of ``speed`` (rpm)."""
        idx = np.searchsorted(np.asarray(self.breaks, dtype=float), np.asarray(speed, dtype=float), side="right")
        return np.asarray(self.ratios, dtype=float)[idx]


@dataclass(frozen=True)
class LumpedParams:
    """Fitted ``v1, v2, v3`` (units of m c / Δt) of one lumped mass, eq. (4)."""

    v1: float
    v2: float
    v3: float = 0.0
    gearbox: Gearbox = field(default_factory=Gearbox)


def heat_inputs(speed: npt.ArrayLike, gearbox: Gearbox | None = None) -> Array:
    """Heat-input regressors ``[n, n / f(n)]`` of eq. (3), speeds in 1000 rpm.

    Parameters
    ----------
    speed : array_like, shape (n,)
        Spindle speed in rpm.
    gearbox : Gearbox, optional

    Returns
    -------
    ndarray, shape (n, 2)
    """
    n = np.asarray(speed, dtype=float) / SPEED_UNIT
    f = (gearbox or Gearbox()).ratio(np.asarray(speed, dtype=float))
    return np.column_stack([n, n / f])


def lumped_coefficients(
    v1: npt.ArrayLike, v2: npt.ArrayLike, v3: npt.ArrayLike, heat: npt.ArrayLike
) -> tuple[Array, Array, Array]:
    """``A``, ``B`` and the per-sample input ``C^j`` of eq. (5) from ``v`` (eq. (4), M = 1).

    Parameters
    ----------
    v1, v2, v3 : array_like, broadcastable (e.g. shape (P,) for P candidates)
    heat : array_like, shape (n, 2)
        From :func:`heat_inputs`.

    Returns
    -------
    A, B : ndarray, shape of ``v1``
    C : ndarray, shape ``v1.shape + (n,)``
    """
    v1, v2, v3 = (np.asarray(v, dtype=float) for v in (v1, v2, v3))
    heat = np.asarray(heat, dtype=float)
    denom = 1.0 + v1
    A = 1.0 / denom
    B = v1 / denom
    C = (v2[..., None] * heat[:, 0] + v3[..., None] * heat[:, 1]) / denom[..., None]
    return A, B, C


def lumped_simulate(
    A: npt.ArrayLike, B: npt.ArrayLike, C: npt.ArrayLike, ambient: npt.ArrayLike, t0: npt.ArrayLike
) -> Array:
    """Open-loop temperatures of eq. (4) from the initial value ``t0``.

    ``T^0 = t0``, ``T^j = A T^{j-1} + B T_e^j + C^j`` for j = 1…n-1; a first-order IIR
    filter, run by :func:`scipy.signal.lfilter` with the initial state.

    Parameters
    ----------
    A, B : float or array_like, shape (P,)
    C : array_like, shape (n,) or (P, n)
    ambient : array_like, shape (n,)
        Environment temperature T_e (°C).
    t0 : float or array_like, shape (P,)

    Returns
    -------
    ndarray, shape (n,) or (P, n)
    """
    A_arr = np.atleast_1d(np.asarray(A, dtype=float))
    single = np.ndim(A) == 0 and np.ndim(C) == 1
    B_arr = np.broadcast_to(np.asarray(B, dtype=float), A_arr.shape)
    C_arr = np.atleast_2d(np.asarray(C, dtype=float))
    C_arr = np.broadcast_to(C_arr, (A_arr.size, C_arr.shape[-1]))
    t0_arr = np.broadcast_to(np.asarray(t0, dtype=float), A_arr.shape)
    te = np.asarray(ambient, dtype=float)
    out = np.empty((A_arr.size, te.size))
    for p in range(A_arr.size):
        drive = B_arr[p] * te[1:] + C_arr[p, 1:]
        out[p, 0] = t0_arr[p]
        if te.size > 1:
            out[p, 1:], _ = lfilter([1.0], [1.0, -A_arr[p]], drive, zi=[A_arr[p] * t0_arr[p]])
    return out[0] if single else out


def lumped_equation_error(
    measured: npt.ArrayLike, ambient: npt.ArrayLike, heat: npt.ArrayLike, n_genes: int = 2
) -> Array:
    """Equation-error estimate of ``v`` from eq. (4) rearranged as a linear regression.

    With M = 1, eq. (4) reads ``T^j − T^{j−1} = v1 (T_e^j − T^j) + v2 n^j + v3 n^j / f``,
    linear in ``v``; :func:`scipy.optimize.lsq_linear` solves it with ``v > 0``.  The
    measured ``T^j`` on the right makes this estimate biased by sensor noise, so it
    only seeds the GA, which then minimises the simulation error F1.

    Returns
    -------
    ndarray, shape (n_genes,)
    """
    T = np.asarray(measured, dtype=float)
    te = np.asarray(ambient, dtype=float)
    heat = np.asarray(heat, dtype=float)
    X = np.column_stack([te[1:] - T[1:], heat[1:, : n_genes - 1]])
    tiny = 1e-9
    res = lsq_linear(X, np.diff(T), bounds=(np.full(n_genes, tiny), np.full(n_genes, np.inf)))
    rates: Array = np.maximum(res.x, tiny)
    return rates


def fit_lumped(
    measured: npt.ArrayLike,
    ambient: npt.ArrayLike,
    speed: npt.ArrayLike,
    *,
    gearbox: Gearbox | None = None,
    rng: np.random.Generator | None = None,
    pop_size: int = 40,
    n_gen: int = 60,
    p_crossover: float = 0.7,
    p_mutation: float = 0.02,
    log10_bounds: tuple[float, float] = (-6.0, 1.0),
) -> tuple[LumpedParams, SearchResult]:
    """Fit ``v1, v2 (, v3)`` of one lumped mass by the GA on F1 (Wang et al. 2017, eq. (12)).

    The genes are ``log10 v``: the coefficients are positive (a conductance and heat
    generation) and span decades between machines, which a linear box would not
    search evenly.  One individual of the first generation is the equation-error
    estimate (:func:`lumped_equation_error`): with crossover 0.7 and mutation 0.02
    the paper's GA mostly recombines its first generation, and a random first
    generation over seven decades rarely holds the answer.

    Parameters
    ----------
    measured : array_like, shape (n,)
        Sensor temperature T_M (°C).
    ambient : array_like, shape (n,)
    speed : array_like, shape (n,)
        Spindle speed (rpm).
    gearbox : Gearbox, optional
        With a non-trivial gearbox a third gene ``v3`` is fitted.
    rng : numpy.random.Generator
    pop_size, n_gen, p_crossover, p_mutation : GA settings (paper: 0.7, 0.02).
    log10_bounds : (float, float)
        Box of every gene in decades.

    Returns
    -------
    LumpedParams, SearchResult
    """
    gearbox = gearbox or Gearbox()
    T = np.asarray(measured, dtype=float)
    te = np.asarray(ambient, dtype=float)
    heat = heat_inputs(speed, gearbox)
    n_genes = 2 if gearbox.trivial else 3

    def objective(pop: Array) -> Array:
        v = 10.0**pop
        v3 = v[:, 2] if n_genes == 3 else np.zeros(len(pop))
        A, B, C = lumped_coefficients(v[:, 0], v[:, 1], v3, heat)
        return rmsv(T, lumped_simulate(A, B, C, te, T[0]))  # F1 of eq. (12) = RMSV of eq. (13)

    lo = np.full(n_genes, log10_bounds[0])
    hi = np.full(n_genes, log10_bounds[1])
    seed_x = np.clip(np.log10(lumped_equation_error(T, te, heat, n_genes)), lo, hi)
    res = genetic_algorithm(
        objective,
        lo,
        hi,
        pop_size=pop_size,
        n_gen=n_gen,
        p_crossover=p_crossover,
        p_mutation=p_mutation,
        rng=rng,
        x0=seed_x,
    )
    v = 10.0**res.x
    params = LumpedParams(float(v[0]), float(v[1]), float(v[2]) if n_genes == 3 else 0.0, gearbox)
    return params, res
