"""The diagnosis of one series: residual, traced effects, error before and after, walk forward."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ParameterError
from setupfix.core.params import Constraint, Interval, ValidatedParams
from setupfix.diagnose.factors import FactorTests, Term, factor_tests
from setupfix.diagnose.fit import Fit, fit_model, observations
from setupfix.diagnose.inference import position_structure
from setupfix.diagnose.log_family import LOG_FAMILY, log_factors, log_family, log_recheck
from setupfix.diagnose.select import Selection, select_effects
from setupfix.diagnose.terms import EffectSpec, Layout, Series
from setupfix.diagnose.walk import (
    CENTRE_FRACTION,
    NextSource,
    WalkForward,
    centred_registers,
    ewma_forecast,
    next_cycle,
    next_source,
    walk_forward,
)

__all__ = ["EffectResult", "ErrorSummary", "Diagnosis", "Diagnoser", "error_summary"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class EffectResult:
    """One effect found: its term, estimate ± standard error, unit, and the RMS once added.

    ``source`` is ``search`` (found by the forward selection) or ``declared`` (a declared
    design factor accepted by its own test; ``p`` its Holm-adjusted per-part p-value, None
    for a lower-order term fitted with an accepted interaction).
    """

    spec: EffectSpec
    estimate: float
    stderr: float
    unit: str
    rms_after: float
    alike: tuple[str, ...] = ()
    source: str = "search"
    p: float | None = None

    @property
    def kind(self) -> str:
        return self.spec.kind

    @property
    def target(self) -> str:
        return self.spec.target

    @property
    def registers(self) -> tuple[str, ...]:
        """A relation's register and every other the series cannot tell from it (empty for other kinds).

        One register: the series names it.  Several: they moved together (or the dimension
        is off by a constant no correction step explains) and any of them may be the one.
        """
        if self.kind != "relation":
            return ()
        return (str(self.spec.register), *(a.rsplit(" ~ ", 1)[1] for a in self.alike))


@dataclass(frozen=True)
class ErrorSummary:
    """Residual of a fit: overall, per dimension and per cycle.

    ``out_of_tolerance`` counts residuals outside their dimension's limits: what
    would stay out of tolerance with the setup state (and effects) perfectly corrected.
    """

    rms: float
    max: float
    out_of_tolerance: int
    rms_by_dimension: Array
    max_by_dimension: Array
    rms_by_cycle: Array
    max_by_cycle: Array


def _rms(values: Array, axis: int | None) -> Array:
    """Root mean square over ``axis`` of the finite values; NaN where there is none (no warning)."""
    seen = np.isfinite(values)
    count = seen.sum(axis=axis)
    total = np.where(seen, values, 0.0) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.where(count > 0, total.sum(axis=axis) / np.maximum(count, 1), np.nan))


def error_summary(residual: Array, lower: Array, upper: Array) -> ErrorSummary:
    """Summarise a residual field (n_cycles, n_dimensions), NaN where absent."""
    a = np.abs(residual)
    with np.errstate(invalid="ignore"):
        by_dim = _rms(residual, axis=0) if residual.size else np.zeros(0)
        by_cyc = _rms(residual, axis=1) if residual.size else np.zeros(0)
        out = int(np.sum((residual < lower) | (residual > upper)))
    return ErrorSummary(
        rms=float(_rms(residual, axis=None)),
        max=float(np.nanmax(a)) if np.isfinite(a).any() else float("nan"),
        out_of_tolerance=out,
        rms_by_dimension=by_dim,
        max_by_dimension=np.nanmax(np.where(np.isnan(a), -np.inf, a), axis=0),
        rms_by_cycle=by_cyc,
        max_by_cycle=np.nanmax(np.where(np.isnan(a), -np.inf, a), axis=1),
    )


#: ``Diagnosis.next_from`` of a diagnosis built without a rule (the augmented model, as before the rule).
UNSET = NextSource("augmented", "")


@dataclass(frozen=True)
class Diagnosis:
    """Everything ``setupfix diagnose`` reports about one series.

    Attributes
    ----------
    layout, series
    before, after : Fit
        Declared model; declared model with the effects found.
    selection : Selection
    effects : tuple of EffectResult
    error_before, error_after : ErrorSummary
    walk : WalkForward or None
        None for series too short to walk.
    forecast : ndarray (n_dimensions,) [model unit]
        Deviations the augmented model expects on the next cycle with the registers as they are.
    notes : tuple of str
    next_from : NextSource
        The model the next correction comes from (:func:`~setupfix.diagnose.walk.next_source`).
    next_forecast : ndarray (n_dimensions,) [model unit]
        That model's forecast of the next cycle (EWMA: the smoothed disturbance at the registers now).
    centred : ndarray of bool (n_registers,)
        Registers the next correction must not move: their dimensions sat within
        ``centre_fraction`` half tolerances of the centre on the last two parts and a
        model with effects does not forecast them to leave it
        (:func:`~setupfix.diagnose.walk.centred_registers`).
    factors : FactorTests or None
        The tests of the declared design factors (None when none were declared).
    """

    layout: Layout
    series: Series
    before: Fit
    after: Fit
    selection: Selection
    effects: tuple[EffectResult, ...]
    error_before: ErrorSummary
    error_after: ErrorSummary
    walk: WalkForward | None
    forecast: Array
    notes: tuple[str, ...]
    next_from: NextSource = UNSET
    next_forecast: Array | None = None
    centred: npt.NDArray[np.bool_] | None = None
    factors: FactorTests | None = None

    def relation_matrix(self) -> Array:
        """Composite matrix the corrections are mapped through: C with the relations found whose
        register is named (:meth:`Fit.relation_matrix`; a relation shared by registers that moved
        together changes nothing)."""
        return self.after.relation_matrix(self.layout, self.selection.unnamed)

    def next_matrix(self) -> Array:
        """Composite matrix of the model the next correction comes from (``next_from``)."""
        if self.next_from.source == "augmented":
            return self.relation_matrix()
        if self.next_from.source == "declared":
            return self.before.relation_matrix(self.layout, ())
        return self.layout.composite


class Diagnoser(ValidatedParams):
    """Diagnose a series against its declared process model.

    Parameters
    ----------
    alpha : float, default=0.01
        Family-wise level of each selection step (Bonferroni).
    max_effects : int, default=4
    n_folds : int, default=5
        Cross-validation folds over cycles.
    walk : bool, default=True
        Walk forward (cost: one selection every ``reselect_every`` cycles).
    min_train : int, default=5
    reselect_every : int or None
    lam : float or None, default=0.3
        EWMA weight of the run-to-run baseline (None: no EWMA; the effects found then
        have to beat the declared model).
    centre_fraction : float, default=0.25
        Half tolerances within which a dimension counts as centred (the next correction
        holds a register whose dimensions all sat there on the last two parts).
    score_from : int or None, default=None
        First cycle (1, 2, … in the series' order) the walk forward is scored from; None: the
        first from which the search's choice is stable (:func:`~setupfix.diagnose.walk.stable_from`).
    log_first : bool, default=True
        Without declared factors, test the process log's own columns first, as one family
        (:mod:`~setupfix.diagnose.log_family`), before the broad search.
    """

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "alpha": [Interval(float, 0, 1, closed="neither")],
        "max_effects": [Interval(int, 0, 20)],
        "n_folds": [Interval(int, 2, 50)],
        "walk": [bool],
        "min_train": [Interval(int, 1, None)],
        "reselect_every": [Interval(int, 1, None), None],
        "lam": [Interval(float, 0, 1, closed="right"), None],
        "centre_fraction": [Interval(float, 0, 1, closed="both")],
        "score_from": [Interval(int, 1, None), None],
        "log_first": [bool],
    }

    def __init__(
        self,
        *,
        alpha: float = 0.01,
        max_effects: int = 4,
        n_folds: int = 5,
        walk: bool = True,
        min_train: int = 5,
        reselect_every: int | None = None,
        lam: float | None = 0.3,
        centre_fraction: float = CENTRE_FRACTION,
        score_from: int | None = None,
        log_first: bool = True,
    ) -> None:
        self.alpha = alpha
        self.max_effects = max_effects
        self.n_folds = n_folds
        self.walk = walk
        self.min_train = min_train
        self.reselect_every = reselect_every
        self.lam = lam
        self.centre_fraction = centre_fraction
        self.score_from = score_from
        self.log_first = log_first

    def run(
        self, layout: Layout, series: Series, *, declared: tuple[EffectSpec, ...] = (), factors: tuple[Term, ...] = ()
    ) -> Diagnosis:
        """Fit, trace, add, walk forward and forecast.

        ``declared`` effects (the model's ``[effects]``) belong to the declared model.
        ``factors`` are declared design factors (:mod:`setupfix.diagnose.factors`): tested
        first, as a family of their own (Holm at ``alpha``); those accepted enter the model
        like effects found, and the search runs with them in its base.  Without them, a
        process log's own columns are tested first the same way (``log_first``).

        Raises
        ------
        ParameterError
            If a hyper-parameter is out of range or the series has no measured cell.
        """
        self.validate_params()
        obs = observations(layout, series)
        if obs.n == 0:
            raise ParameterError("diagnose: the series has no measured dimension")
        tests: FactorTests | None = None
        if factors:
            tests = factor_tests(layout, series, factors, alpha=self.alpha, obs=obs, declared=declared)
        elif self.log_first and log_factors(series):
            tests = log_family(layout, series, alpha=self.alpha, obs=obs, declared=declared)
        pre = tests.found if tests is not None else ()
        selection = select_effects(
            layout,
            series,
            alpha=self.alpha,
            max_effects=self.max_effects,
            n_folds=self.n_folds,
            obs=obs,
            declared=declared + pre,
        )
        if tests is not None and tests.family == LOG_FAMILY and selection.found:
            tests = log_recheck(layout, series, tests, selection.found, alpha=self.alpha, obs=obs, declared=declared)
            pre = tests.found
        found = pre + selection.found
        before = fit_model(layout, series, declared, obs=obs)
        after = fit_model(layout, series, declared + found, obs=obs)
        effects = []
        alike = ((),) * len(pre) + selection.alike_of_found()
        for i, spec in enumerate(found):
            est, se = after.estimate(len(declared) + i)
            partial: Fit = fit_model(layout, series, declared + found[: i + 1], obs=obs)
            test = tests.test_of(spec) if tests is not None and i < len(pre) else None
            effects.append(
                EffectResult(
                    spec,
                    est,
                    se,
                    spec.unit(layout.unit),
                    error_summary(partial.residual, layout.lower, layout.upper).rms,
                    alike[i],
                    tests.family if tests is not None and i < len(pre) else "search",
                    test.p_holm if test is not None else None,
                )
            )
        walk = None
        notes = list(selection.notes) + (list(tests.notes) if tests is not None else [])
        structure = position_structure(layout, series, after, self.alpha)
        if structure is not None:
            notes.append(structure)
        if self.walk and series.n_cycles >= self.min_train + 5:
            walk = walk_forward(
                layout,
                series,
                score_composite=after.relation_matrix(layout, selection.unnamed),
                min_train=self.min_train,
                reselect_every=self.reselect_every,
                lam=self.lam,
                alpha=self.alpha,
                declared=declared,
                factors=factors,
                log_first=self.log_first,
                score_from=None if self.score_from is None else self.score_from - 1,
            )
            if walk.late and not walk.stated and walk.scored_from is not None:
                notes.append(
                    f"effects accepted late: the search's choice is stable only from cycle {walk.scored_from + 1} "
                    f"of {series.n_cycles}; the walk forward is scored from there (the cycles before are its "
                    "learning, scored apart: --score-from states another start)"
                )
        elif self.walk:
            notes.append(
                f"{series.n_cycles} cycle(s): too few to walk forward (needs {self.min_train + 5}: "
                f"{self.min_train} to fit, 5 to score)"
            )
        forecast, _ = next_cycle(layout, series, after)
        source = next_source(walk, bool(found), ewma=self.lam is not None)
        if source.source == "augmented":
            chosen = forecast
        elif source.source == "declared":
            chosen = next_cycle(layout, series, before)[0]
        else:
            chosen = ewma_forecast(layout, series, float(self.lam or 1.0))
        out = Diagnosis(
            layout,
            series,
            before,
            after,
            selection,
            tuple(effects),
            error_summary(before.residual, layout.lower, layout.upper),
            error_summary(after.residual, layout.lower, layout.upper),
            walk,
            forecast,
            tuple(notes),
            source,
            chosen,
            factors=tests,
        )
        return dataclasses.replace(out, centred=self._centred(out, chosen))

    def _centred(self, d: Diagnosis, chosen: Array) -> npt.NDArray[np.bool_]:
        """The centre rule: registers whose dimensions sat at the centre on the last two parts."""
        s, lay = d.series, d.layout
        C = d.next_matrix()
        pending = s.pending if s.pending.size == lay.n_registers else np.zeros(lay.n_registers)
        last = slice(max(s.n_cycles - 2, 0), s.n_cycles)
        recent = s.deviation[last] + (s.applied[-1] + pending - s.applied[last]) @ C
        predicts = (d.next_from.source == "augmented" and bool(d.effects)) or (
            d.next_from.source == "declared" and bool(d.before.specs)
        )
        return centred_registers(
            C, recent, chosen if predicts else None, lay.lower, lay.upper, fraction=self.centre_fraction
        )
