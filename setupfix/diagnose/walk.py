"""Prove it on later parts: walk forward through the series, and forecast the next cycle.

At each cycle k (from ``min_train`` on) every controller chooses the register state
v_k from the cycles before k only; the cycle's actual deviations are then moved to
what that state would have given, y'_k = y_k + (v_k − u_k) · C_s, and scored by the
unilateral error budget (Stryczek 2014, f1: smallest distance of a deviation to its
nearer limit).  C_s is the composite matrix with the relation effects found on the
whole series (the declared C when none was found), the best estimate of how the
machine answers its registers.  The four controllers:

(a) declared — the setup state fitted on the cycles before (eqs. 3–4 only);
(b) augmented — the same with the effects found added, predicted at cycle k's
    time, parts and temperatures;
(c) EWMA — the classic run-to-run controller (Ingolfsson & Sachs 1993): a per-dimension
    disturbance estimate d ← λ (y − u · C) + (1 − λ) d, λ = ``lam``;
(d) none — the registers stay as at the first scored cycle.

Each maps its predicted deviation to a register state by least squares through its
relation matrix (minimum-norm centring): the difference between (a)–(c) is the model,
never the optimiser.  Effects are re-selected every ``reselect_every`` cycles on the
cycles before (honest: no future data), coefficients refitted at every cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.fit import Fit, fit_model
from setupfix.diagnose.select import select_effects
from setupfix.diagnose.terms import EffectSpec, Layout, Series

__all__ = ["Budget", "WalkForward", "walk_forward", "next_cycle", "margins_of"]

Array = npt.NDArray[np.float64]

CONTROLLERS: tuple[str, ...] = ("declared", "augmented", "ewma", "none")


@dataclass(frozen=True)
class Budget:
    """Scores of one controller over the walked cycles.

    Attributes
    ----------
    budget : ndarray (n_scored,) [model unit]
        Unilateral error budget of each cycle (negative: out of tolerance).
    mean_budget, worst_budget : float
    rms : float
        RMS of the deviations reached.
    out_of_tolerance : int
        Cells outside their limits.
    """

    budget: Array
    mean_budget: float
    worst_budget: float
    rms: float
    out_of_tolerance: int


@dataclass(frozen=True)
class WalkForward:
    """Walk-forward result: scored cycles and one :class:`Budget` per controller."""

    cycles: tuple[int, ...]
    budgets: dict[str, Budget]


def margins_of(y: Array, lower: Array, upper: Array) -> Array:
    """Distance of each deviation to its nearer limit (negative outside), NaN where absent."""
    out: Array = np.minimum(upper - y, y - lower)
    return out


def _score(dev: Array, lower: Array, upper: Array) -> Budget:
    m = margins_of(dev, lower, upper)
    budget = np.nanmin(np.where(np.isnan(m), np.inf, m), axis=1) if m.size else np.zeros(0)
    budget = np.where(np.isinf(budget), np.nan, budget)
    return Budget(budget, float(np.nanmean(budget)), float(np.nanmin(budget)), float(np.sqrt(np.nanmean(dev ** 2))),
                  int(np.sum(m < 0)))


def _state(pred: Array, C: Array) -> Array:
    """Register state v minimising ‖pred + v · C‖ (minimum norm); absent dimensions ignored."""
    ok = np.isfinite(pred)
    v, *_ = np.linalg.lstsq(C[:, ok].T, -pred[ok], rcond=None)
    out: Array = v
    return out


def walk_forward(layout: Layout, series: Series, *, score_composite: Array | None = None, min_train: int = 5,
                 reselect_every: int | None = None, lam: float = 0.3, alpha: float = 0.01,
                 declared: tuple[EffectSpec, ...] = ()) -> WalkForward:
    """Walk forward through ``series``; see the module text.

    Parameters
    ----------
    layout, series
    score_composite : ndarray (n_registers, n_dimensions), optional
        C_s (default: the declared composite).
    min_train : int, default=5
        Cycles before the first scored one.
    reselect_every : int, optional
        Cycles between effect selections (default max(5, n_cycles // 8)).
    lam : float, default=0.3
        EWMA weight.
    alpha : float
        Level of the selection (as :func:`select_effects`).
    declared : tuple of EffectSpec
        Effects of the model's ``[effects]``: part of the declared model (a).

    Returns
    -------
    WalkForward
    """
    n = series.n_cycles
    C = layout.composite
    Cs = C if score_composite is None else score_composite
    every = reselect_every or max(5, n // 8)
    y = series.deviation
    z_obs = y - series.applied @ C
    scored = list(range(min(min_train, n), n))
    reached = {name: np.full((len(scored), layout.n_dimensions), np.nan) for name in CONTROLLERS}
    specs: tuple[EffectSpec, ...] = ()
    ewma = np.where(np.isfinite(z_obs[0]), z_obs[0], 0.0)
    for k in range(1, min(min_train, n)):
        ewma = np.where(np.isfinite(z_obs[k]), lam * z_obs[k] + (1 - lam) * ewma, ewma)
    base_state = series.applied[scored[0]] if scored else np.zeros(layout.n_registers)
    for pos, k in enumerate(scored):
        train = series.take(np.arange(k))
        one = series.take([k])
        if pos == 0 or (k - scored[0]) % every == 0:
            specs = select_effects(layout, train, alpha=alpha, declared=declared).found
        states: dict[str, Array] = {}
        base = fit_model(layout, train, declared)
        states["declared"] = _state(base.predict(layout, one, applied=False)[0], base.relation_matrix(layout))
        aug: Fit = fit_model(layout, train, declared + specs) if specs else base
        states["augmented"] = _state(aug.predict(layout, one, applied=False)[0], aug.relation_matrix(layout))
        states["ewma"] = _state(ewma, C)
        states["none"] = base_state
        for name, v in states.items():
            reached[name][pos] = y[k] + (v - series.applied[k]) @ Cs
        ewma = np.where(np.isfinite(z_obs[k]), lam * z_obs[k] + (1 - lam) * ewma, ewma)
    budgets = {name: _score(dev, layout.lower, layout.upper) for name, dev in reached.items()}
    return WalkForward(tuple(scored), budgets)


def next_cycle(layout: Layout, series: Series, fit: Fit) -> tuple[Array, Series]:
    """Forecast the deviations of the next cycle with the registers as they are now.

    The next cycle is machined one typical cycle interval (median of the series'
    intervals up to 1 h) after the last, with one more cycle on every tool, the last
    temperatures, and every logged change in effect (``series.pending`` included).

    Returns
    -------
    deviation : ndarray (n_dimensions,) [model unit]
    covariates : Series
        The one-cycle series of the forecast (deviation NaN).
    """
    last = series.n_cycles - 1
    gaps = np.diff(series.time)
    step = float(np.median(gaps[gaps <= 1.0])) if np.any(gaps <= 1.0) else (float(np.median(gaps)) if gaps.size else 0.0)
    pending = series.pending if series.pending.size == layout.n_registers else np.zeros(layout.n_registers)
    applied = series.applied[last] + pending
    nxt = Series(np.full((1, layout.n_dimensions), np.nan), series.time[[last]] + step, applied[None, :],
                 series.parts[[last]] + 1, series.temperature[[last]], series.channels, ("next",), series.origin)
    z = fit.predict(layout, nxt)[0]
    dev: Array = z + applied @ layout.composite
    return dev, nxt
