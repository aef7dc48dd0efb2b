"""Prove it on later parts: walk forward through the series, and forecast the next cycle.

At each cycle k (from ``min_train`` on) every controller chooses the register state
v_k from the cycles before k only; the cycle's actual deviations are then moved to
what that state would have given, y'_k = y_k + (v_k − u_k) · C_s, and scored as a shop
scores parts: the distance of every dimension to its tolerance centre (RMS and mean
|·|, one-sided limits: the finite limit's side of 0, :func:`setupfix.correction.explain.targets`),
the cells out of tolerance, and the unilateral error budget (Stryczek 2014, f1: smallest
distance of a deviation to its nearer limit).  C_s is the composite matrix with the relation effects found on the
whole series (the declared C when none was found), the best estimate of how the
machine answers its registers.  The four controllers:

(a) declared — the setup state fitted on the cycles before (eqs. 3–4 only);
(b) augmented — the same with the effects found added, predicted at cycle k's
    time, parts and temperatures;
(c) EWMA — the classic run-to-run controller (Ingolfsson & Sachs 1993): a per-dimension
    disturbance estimate d ← λ (y − u · C) + (1 − λ) d, λ = ``lam``;
(d) none — the registers stay as at the first scored cycle.

Each maps its predicted deviation to the register state that brings every dimension
closest to its tolerance centre, by least squares through its relation matrix
(minimum norm): the difference between (a)–(c) is the model,
never the optimiser.  Effects are re-selected every ``reselect_every`` cycles on the
cycles before (honest: no future data), coefficients refitted at every cycle.

Learning is kept apart from scoring.  Under shared per-part noise an effect is accepted
only after some tens of parts, and before that the selection on the few parts seen may
take a wrong term: scoring those cycles judges the search's learning, not the model it
settles on.  The walk is therefore scored from a stated cycle on: the first cycle from
which the selection's choice no longer changes (:func:`stable_from`: the same terms, level
positions and time constants aside, at every later selection), or the cycle the caller
gives (``score_from``); at least :data:`MIN_SCORED` cycles are scored.  Both scores are
kept: ``budgets`` over the scored cycles (what :func:`next_source` judges) and ``whole``
over every cycle walked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.correction.explain import targets
from setupfix.diagnose.covariates import typical_step
from setupfix.diagnose.factors import Term, factor_tests
from setupfix.diagnose.fit import RELATION_T, Fit, row_space_basis
from setupfix.diagnose.log_family import log_family
from setupfix.diagnose.select import select_effects
from setupfix.diagnose.terms import EffectSpec, Layout, Series, effect_field

__all__ = [
    "Budget",
    "WalkForward",
    "walk_forward",
    "next_cycle",
    "margins_of",
    "NextSource",
    "next_source",
    "centred_registers",
    "CENTRE_FRACTION",
    "MIN_SCORED",
    "stable_from",
]

Array = npt.NDArray[np.float64]

CONTROLLERS: tuple[str, ...] = ("declared", "augmented", "ewma", "none")

#: Fewest cycles a walk is scored on (a stated or stable start later than that is moved back).
MIN_SCORED = 5


@dataclass(frozen=True)
class Budget:
    """Scores of one controller over the walked cycles.

    Attributes
    ----------
    budget : ndarray (n_scored,) [model unit]
        Unilateral error budget of each cycle (negative: out of tolerance).
    mean_budget, worst_budget : float
    rms : float
        RMS of the deviations reached (from nominal).
    out_of_tolerance : int
        Cells outside their limits.
    centre_rms, centre_mean_abs : float [model unit]
        RMS and mean |·| of every reached dimension's distance to its tolerance centre.
    """

    budget: Array
    mean_budget: float
    worst_budget: float
    rms: float
    out_of_tolerance: int
    centre_rms: float = float("nan")
    centre_mean_abs: float = float("nan")


@dataclass(frozen=True)
class WalkForward:
    """Walk-forward result: scored cycles and one :class:`Budget` per controller.

    Attributes
    ----------
    cycles : tuple of int
        The scored cycles (indices into the series), from ``scored_from`` on.
    budgets : dict of str to Budget
        Scores over ``cycles``: what the next-correction rule judges.
    whole : dict of str to Budget or None
        Scores over every cycle walked (None: the same as ``budgets``, scored from the first).
    walked : tuple of int
        Every cycle walked (the learning period included).
    scored_from : int or None
        First scored cycle (index); None when it is the first walked.
    stated : bool
        ``scored_from`` was given by the caller (``--score-from``), not found stable.
    choices : tuple of (int, tuple of str)
        The selection at each re-selection: its cycle and the terms chosen (targets).
    """

    cycles: tuple[int, ...]
    budgets: dict[str, Budget]
    whole: dict[str, Budget] | None = None
    walked: tuple[int, ...] = ()
    scored_from: int | None = None
    stated: bool = False
    choices: tuple[tuple[int, tuple[str, ...]], ...] = ()

    @property
    def late(self) -> bool:
        """True when the scored cycles start after the first walked (learning left out)."""
        return self.scored_from is not None


def _choice_key(spec: EffectSpec) -> str:
    """A term as the stability of a choice sees it: kind and target, refinements (step time, τ) aside."""
    if spec.kind == "level":
        return f"level {spec.register or 'all tools'}"
    if spec.kind == "drift":
        return f"drift {spec.shape}"
    return f"{spec.kind} {spec.target}"


def stable_from(choices: list[tuple[int, tuple[str, ...]]]) -> int | None:
    """Cycle of the earliest selection from which every later selection made the same choice (None: none)."""
    if not choices:
        return None
    last = set(choices[-1][1])
    k = choices[-1][0]
    for cycle, chosen in reversed(choices):
        if set(chosen) != last:
            break
        k = cycle
    return k


def margins_of(y: Array, lower: Array, upper: Array) -> Array:
    """Distance of each deviation to its nearer limit (negative outside), NaN where absent."""
    out: Array = np.minimum(upper - y, y - lower)
    return out


def _score(dev: Array, lower: Array, upper: Array) -> Budget:
    m = margins_of(dev, lower, upper)
    budget = np.nanmin(np.where(np.isnan(m), np.inf, m), axis=1) if m.size else np.zeros(0)
    budget = np.where(np.isinf(budget), np.nan, budget)
    off = dev - targets(lower, upper)
    return Budget(
        budget,
        float(np.nanmean(budget)),
        float(np.nanmin(budget)),
        float(np.sqrt(np.nanmean(dev**2))),
        int(np.sum(m < 0)),
        float(np.sqrt(np.nanmean(off**2))),
        float(np.nanmean(np.abs(off))),
    )


def _state(pred: Array, C: Array, target: Array) -> Array:
    """Register state v minimising ‖pred + v · C − target‖ (minimum norm); absent dimensions ignored.

    pred, target : ndarray (n_dimensions,) [model unit]; C : (n_registers, n_dimensions) → (n_registers,)
    """
    ok = np.isfinite(pred)
    out: Array = np.asarray(np.linalg.lstsq(C[:, ok].T, target[ok] - pred[ok], rcond=None)[0], dtype=float)
    return out


def _grid(
    layout: Layout, series: Series, specs: tuple[EffectSpec, ...], basis: Array, unnamed: tuple[EffectSpec, ...] = ()
) -> tuple[Array, npt.NDArray[np.bool_], list[tuple[int, int, int]]]:
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

    def __init__(
        self,
        layout: Layout,
        series: Series,
        specs: tuple[EffectSpec, ...],
        basis: Array,
        z: Array,
        upto: int,
        unnamed: tuple[EffectSpec, ...] = (),
    ) -> None:
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
        G = self.G[self.seen : k]
        z = self.z[self.seen : k]
        ok = np.isfinite(z)
        Gm = np.where(ok[:, :, None], G, 0.0)
        zm = np.where(ok, z, 0.0)
        self.xtx += np.einsum("kdp,kdq->pq", Gm, Gm)
        self.xtz += np.einsum("kdp,kd->p", Gm, zm)
        self.ztz += float(np.sum(zm**2))
        self.n += int(ok.sum())
        self.seen = k

    def state(self, k: int, target: Array) -> Array:
        """Register state the fitted model recommends for cycle ``k`` (steering to ``target``)."""
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
        return _state(pred, C, target)


def walk_forward(
    layout: Layout,
    series: Series,
    *,
    score_composite: Array | None = None,
    min_train: int = 5,
    reselect_every: int | None = None,
    lam: float | None = 0.3,
    alpha: float = 0.01,
    declared: tuple[EffectSpec, ...] = (),
    factors: tuple[Term, ...] = (),
    log_first: bool = False,
    score_from: int | None = None,
) -> WalkForward:
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
    lam : float or None, default=0.3
        EWMA weight (None: no EWMA controller).
    alpha : float
        Level of the selection (as :func:`select_effects`).
    declared : tuple of EffectSpec
        Effects of the model's ``[effects]``: part of the declared model (a).
    factors : tuple of Term
        Declared design factors: tested on the past at each selection, those accepted
        part of the augmented model (b) with the effects the search finds.
    log_first : bool, default=False
        Without ``factors``, the process log's own columns tested first on the past at each
        selection (:mod:`~setupfix.diagnose.log_family`).
    score_from : int, optional
        First cycle scored (index into the series); default the first from which the
        selection's choice is stable (:func:`stable_from`).  Moved back so that at least
        :data:`MIN_SCORED` cycles are scored, and never before ``min_train``.

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
    target = targets(layout.lower, layout.upper)
    scored = list(range(min(min_train, n), n))
    names = tuple(c for c in CONTROLLERS if lam is not None or c != "ewma")
    reached = {name: np.full((len(scored), layout.n_dimensions), np.nan) for name in names}
    w = 1.0 if lam is None else lam
    ewma = np.where(np.isfinite(z_obs[0]), z_obs[0], 0.0)
    for k in range(1, min(min_train, n)):
        ewma = np.where(np.isfinite(z_obs[k]), w * z_obs[k] + (1 - w) * ewma, ewma)
    base_state = series.applied[scored[0]] if scored else np.zeros(layout.n_registers)
    decl = _Running(layout, series, declared, basis, z_obs, scored[0]) if scored else None
    aug = decl
    choices: list[tuple[int, tuple[str, ...]]] = []
    for pos, k in enumerate(scored):
        assert decl is not None
        decl.add_until(k)
        if pos == 0 or (k - scored[0]) % every == 0:
            past = series.take(np.arange(k))
            if factors:
                pre = factor_tests(layout, past, factors, alpha=alpha, declared=declared).found
            elif log_first:
                pre = log_family(layout, past, alpha=alpha, declared=declared).found
            else:
                pre = ()
            sel = select_effects(layout, past, alpha=alpha, declared=declared + pre)
            specs = pre + sel.found
            choices.append((k, tuple(sorted(_choice_key(s) for s in specs))))
            aug = _Running(layout, series, declared + specs, basis, z_obs, k, sel.unnamed) if specs else decl
        assert aug is not None
        aug.add_until(k)
        states = {"declared": decl.state(k, target), "augmented": aug.state(k, target), "none": base_state}
        if lam is not None:
            states["ewma"] = _state(ewma, C, target)
        for name, v in states.items():
            reached[name][pos] = y[k] + (v - series.applied[k]) @ Cs
        ewma = np.where(np.isfinite(z_obs[k]), w * z_obs[k] + (1 - w) * ewma, ewma)
    whole = {name: _score(dev, layout.lower, layout.upper) for name, dev in reached.items()}
    if not scored:
        return WalkForward((), whole)
    start = stable_from(choices) if score_from is None else score_from
    start = int(
        np.clip(start if start is not None else scored[0], scored[0], max(scored[-1] - MIN_SCORED + 1, scored[0]))
    )
    if start == scored[0]:
        return WalkForward(tuple(scored), whole, None, tuple(scored), None, score_from is not None, tuple(choices))
    keep = slice(start - scored[0], None)
    budgets = {name: _score(dev[keep], layout.lower, layout.upper) for name, dev in reached.items()}
    return WalkForward(
        tuple(scored[keep]), budgets, whole, tuple(scored), start, score_from is not None, tuple(choices)
    )


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
    nxt = Series(
        np.full((1, layout.n_dimensions), np.nan),
        series.time[[last]] + step,
        applied[None, :],
        series.parts[[last]] + 1,
        series.temperature[[last]],
        series.channels,
        ("next",),
        series.origin,
    )
    z = fit.predict(layout, nxt)[0]
    dev: Array = z + applied @ layout.composite
    return dev, nxt


#: Half tolerances within which a dimension counts as centred (:func:`centred_registers`).
CENTRE_FRACTION = 0.25


@dataclass(frozen=True)
class NextSource:
    """Which model the next correction is computed from, and why.

    Attributes
    ----------
    source : {"augmented", "ewma", "declared"}
    reason : str
        The rule and the walk's numbers behind the choice (one line).
    """

    source: str
    reason: str


def next_source(walk: WalkForward | None, found: bool, *, ewma: bool = True) -> NextSource:
    """The rule by which an effect earns its way into the next correction.

    The augmented model (declared + effects found) is used only when, in the scored part
    of the walk forward (:class:`WalkForward` ``budgets``: the learning period left out),
    it beat EWMA: a smaller RMS distance to the tolerance centre **and** no
    more cells out of tolerance.  Otherwise the next correction comes from EWMA (from
    the declared model when no EWMA is configured, ``ewma=False``).  Without effects
    found the declared model is the augmented one and is used as it is; without a walk
    (series too short, or walk off) no effect has been proven and the declared model is
    used.  Where the walk's augmented model never differed from the declared one (no effect
    taken on the past parts: the same scores), it is called the declared model, never "augmented".
    """
    if not found:
        return NextSource("declared", "no effect found: next correction from the declared model")
    fallback = "ewma" if ewma else "declared"
    if walk is None:
        return NextSource(
            "declared",
            "the effects found are not proven on later parts (no walk forward): "
            "next correction from the declared model",
        )
    a = walk.budgets["augmented"]
    other = walk.budgets.get(fallback, walk.budgets["declared"])
    numbers = (
        f"walk forward over {len(walk.cycles)} cycle(s): augmented centre RMS {a.centre_rms:.4g}, "
        f"{a.out_of_tolerance} out of tolerance; {fallback} {other.centre_rms:.4g}, {other.out_of_tolerance}"
    )
    if walk.late and walk.whole is not None and walk.scored_from is not None:
        wa, wo = walk.whole["augmented"], walk.whole.get(fallback, walk.whole["declared"])
        why = "as stated" if walk.stated else "where the search's choice became stable"
        numbers = (
            f"walk forward scored from cycle {walk.scored_from + 1} ({why}) over {len(walk.cycles)} cycle(s): "
            f"augmented centre RMS {a.centre_rms:.4g}, {a.out_of_tolerance} out of tolerance; {fallback} "
            f"{other.centre_rms:.4g}, {other.out_of_tolerance}; over all {len(walk.walked)} walked: augmented "
            f"{wa.centre_rms:.4g}, {fallback} {wo.centre_rms:.4g}"
        )
    dec = walk.budgets["declared"]
    same = np.array_equal(a.budget, dec.budget, equal_nan=True) and (a.centre_rms, a.rms, a.out_of_tolerance) == (
        dec.centre_rms,
        dec.rms,
        dec.out_of_tolerance,
    )
    if a.centre_rms < other.centre_rms and a.out_of_tolerance <= other.out_of_tolerance:
        if same:  # the walk never took an effect: what beat the fallback is the declared model
            return NextSource(
                "declared",
                f"the walk forward's augmented model is the declared one (no effect taken on the past parts) and "
                f"beat {fallback} ({numbers}): next correction from the declared model",
            )
        return NextSource(
            "augmented", f"the effects found beat {fallback} ({numbers}): next correction from the augmented model"
        )
    return NextSource(
        fallback,
        f"the effects found did not beat {fallback} ({numbers}): next correction from "
        f"{'EWMA' if fallback == 'ewma' else 'the declared model'}, the effects left out",
    )


def centre_half_width(lower: Array, upper: Array) -> Array:
    """Half tolerance around :func:`~setupfix.correction.explain.targets`.

    One-sided: the distance of the finite limit to it.

    lower, upper : ndarray (m,) [unit] → ndarray (m,) [unit]
    """
    t = targets(lower, upper)
    both = np.isfinite(lower) & np.isfinite(upper)
    one = np.where(np.isfinite(lower), lower, upper)
    out: Array = np.where(both, (upper - lower) / 2, np.abs(one - t))
    return out


def centred_registers(
    composite: Array,
    recent: Array,
    forecast: Array | None,
    lower: Array,
    upper: Array,
    *,
    fraction: float = CENTRE_FRACTION,
) -> npt.NDArray[np.bool_]:
    """Registers whose dimensions all sat near their tolerance centre and are not predicted to leave it.

    A register is held when every dimension it moves (C[i, q] ≠ 0) lies within
    ``fraction`` × half tolerance of its centre (:func:`centre_half_width`) on each of
    the ``recent`` parts where measured (moved to the registers as they are now;
    measured on at least one) and in the ``forecast`` of a model that predicts change
    (effects found or declared); a forecast that is a smoothed past (EWMA, the declared
    setup state alone) is ``None``: the latest parts say more about now than an average.

    Parameters
    ----------
    composite : ndarray (n_registers, n_dimensions)
    recent : ndarray (n_recent, n_dimensions) [unit]
        The latest parts' deviations at the current registers (NaN: not measured).
    forecast : ndarray (n_dimensions,) [unit] or None
        What the model the correction comes from predicts for the next part (None: no prediction of change).
    lower, upper : ndarray (n_dimensions,) [unit]

    Returns
    -------
    ndarray of bool (n_registers,)
    """
    band = fraction * centre_half_width(lower, upper)
    t = targets(lower, upper)
    rows = recent if forecast is None else np.vstack([recent, forecast[None, :]])
    seen = np.isfinite(rows)
    near = ~seen | (np.abs(rows - t) <= band)  # unmeasured cells say nothing
    inside = near.all(axis=0) & np.isfinite(recent).any(axis=0)
    if forecast is not None:
        inside &= np.isfinite(forecast)
    moves = composite != 0
    out: npt.NDArray[np.bool_] = moves.any(axis=1) & ~np.any(moves & ~inside, axis=1)
    return out


def ewma_forecast(layout: Layout, series: Series, lam: float) -> Array:
    """The EWMA controller's forecast of the next part at the registers in effect for it.

    d ← λ z + (1 − λ) d over z = y − u · C (as in the walk), then d + (u_last + pending) · C.
    """
    z = series.deviation - series.applied @ layout.composite
    d = np.where(np.isfinite(z[0]), z[0], np.nan)
    for k in range(1, series.n_cycles):
        d = np.where(np.isfinite(z[k]), np.where(np.isfinite(d), lam * z[k] + (1 - lam) * d, z[k]), d)
    pending = series.pending if series.pending.size == layout.n_registers else np.zeros(layout.n_registers)
    out: Array = d + (series.applied[-1] + pending) @ layout.composite
    return out
