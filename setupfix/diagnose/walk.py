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

from setupfix.diagnose.fit import RELATION_T, Fit, row_space_basis
from setupfix.diagnose.select import select_effects
from setupfix.diagnose.terms import EffectSpec, Layout, Series, effect_field, typical_step

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
    out: Array = np.asarray(np.linalg.lstsq(C[:, ok].T, -pred[ok], rcond=None)[0], dtype=float)
    return out


def _grid(layout: Layout, series: Series, specs: tuple[EffectSpec, ...], basis: Array,
          unnamed: tuple[EffectSpec, ...] = ()) -> tuple[Array, npt.NDArray[np.bool_], list[tuple[int, int, int]]]:
    """Design of the model at every (cycle, dimension), measured or not.

    Returns
    -------
    G : ndarray (n_cycles, n_dimensions, p)
    slope : ndarray of bool (p,)
        Columns of relation slopes that act through the registers (named relations).
    relations : list of (column, register row, dimension column)
        The relations whose register is named (not in ``unnamed``): they change the
        matrix the state is solved through.
    """
    n, d = series.n_cycles, layout.n_dimensions
    blocks = [np.broadcast_to(basis.T, (n, d, basis.shape[0]))]
    slope: list[bool] = [False] * basis.shape[0]
    relations = []
    for spec in specs:
        blocks.append(effect_field(spec, layout, series)[:, :, None])
        # an unnamed relation is predicted at the registers in effect, like the static terms
        slope.append(spec.kind == "relation" and spec not in unnamed)
        if spec.kind == "relation":
            q = layout.dimension_ids.index(str(spec.dimension))
            const = np.zeros((n, d, 1))
            const[:, q, 0] = 1.0
            if spec not in unnamed:
                relations.append((len(slope) - 1, layout.register_ids.index(str(spec.register)), q))
            blocks.append(const)
            slope.append(False)
    return np.concatenate(blocks, axis=2), np.array(slope, dtype=bool), relations


class _Running:
    """Least squares on the cycles seen so far, by accumulated normal equations (XᵀX, Xᵀz)."""

    def __init__(self, layout: Layout, series: Series, specs: tuple[EffectSpec, ...], basis: Array,
                 z: Array, upto: int, unnamed: tuple[EffectSpec, ...] = ()) -> None:
        self.G, self.slope, self.relations = _grid(layout, series, specs, basis, unnamed)
        self.z = z
        self.C = layout.composite
        p = self.G.shape[2]
        self.xtx = np.zeros((p, p))
        self.xtz = np.zeros(p)
        self.ztz = 0.0
        self.n = 0
        self.seen = 0
        self.add_until(upto)

    def add_until(self, k: int) -> None:
        """Take cycles ``seen … k − 1`` in."""
        if k <= self.seen:
            return
        G = self.G[self.seen:k]
        z = self.z[self.seen:k]
        ok = np.isfinite(z)
        Gm = np.where(ok[:, :, None], G, 0.0)
        zm = np.where(ok, z, 0.0)
        self.xtx += np.einsum("kdp,kdq->pq", Gm, Gm)
        self.xtz += np.einsum("kdp,kd->p", Gm, zm)
        self.ztz += float(np.sum(zm ** 2))
        self.n += int(ok.sum())
        self.seen = k

    def state(self, k: int) -> Array:
        """Register state the fitted model recommends for cycle ``k``."""
        coef = np.linalg.lstsq(self.xtx, self.xtz, rcond=1e-12)[0]
        pred = self.G[k][:, ~self.slope] @ coef[~self.slope]
        C = self.C.copy()
        if self.relations:
            inv = np.linalg.pinv(self.xtx, rcond=1e-12)
            rss = max(self.ztz - 2 * coef @ self.xtz + coef @ self.xtx @ coef, 0.0)
            sigma2 = rss / max(self.n - np.linalg.matrix_rank(self.xtx), 1)
            for col, i, q in self.relations:
                if abs(coef[col]) > RELATION_T * np.sqrt(max(sigma2 * inv[col, col], 0.0)):
                    C[i, q] += coef[col]
        return _state(pred, C)


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

    Notes
    -----
    Coefficients are refitted at every cycle from accumulated normal equations, so
    a walk costs one pass over the series plus one selection per ``reselect_every``.
    """
    n = series.n_cycles
    C = layout.composite
    Cs = C if score_composite is None else score_composite
    every = reselect_every or max(5, n // 8)
    y = series.deviation
    z_obs = y - series.applied @ C
    basis = row_space_basis(C)
    scored = list(range(min(min_train, n), n))
    reached = {name: np.full((len(scored), layout.n_dimensions), np.nan) for name in CONTROLLERS}
    ewma = np.where(np.isfinite(z_obs[0]), z_obs[0], 0.0)
    for k in range(1, min(min_train, n)):
        ewma = np.where(np.isfinite(z_obs[k]), lam * z_obs[k] + (1 - lam) * ewma, ewma)
    base_state = series.applied[scored[0]] if scored else np.zeros(layout.n_registers)
    decl = _Running(layout, series, declared, basis, z_obs, scored[0]) if scored else None
    aug = decl
    for pos, k in enumerate(scored):
        assert decl is not None
        decl.add_until(k)
        if pos == 0 or (k - scored[0]) % every == 0:
            sel = select_effects(layout, series.take(np.arange(k)), alpha=alpha, declared=declared)
            specs = sel.found
            aug = _Running(layout, series, declared + specs, basis, z_obs, k, sel.unnamed) if specs else decl
        assert aug is not None
        aug.add_until(k)
        states = {"declared": decl.state(k), "augmented": aug.state(k), "ewma": _state(ewma, C), "none": base_state}
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
    step = typical_step(series.time)
    pending = series.pending if series.pending.size == layout.n_registers else np.zeros(layout.n_registers)
    applied = series.applied[last] + pending
    nxt = Series(np.full((1, layout.n_dimensions), np.nan), series.time[[last]] + step, applied[None, :],
                 series.parts[[last]] + 1, series.temperature[[last]], series.channels, ("next",), series.origin)
    z = fit.predict(layout, nxt)[0]
    dev: Array = z + applied @ layout.composite
    return dev, nxt
