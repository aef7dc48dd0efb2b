"""Safety rules between the optimum and the machine: pure functions, arrays in and out.

The rules follow what every probing and gauging system applies before an offset
reaches a controller (Renishaw Inspection Plus null band / feedback % / upper
tolerance; Siemens measuring cycles' zero-offset range, mean value and dimension
difference check; ISO 14253-1 for decisions under measurement uncertainty):

* **reject band** — a deviation beyond a tolerance limit by more than the band is a
  broken tool, a bad measurement or a wrong part: no correction at all;
* **guard band** — the optimiser works on the tolerance shrunk by g·U at each limit
  (ISO 14253-1 conformance zone), so its margin is a proven margin;
* **cumulative limit** — |applied since the last reset + change| stays within it;
* **per-step clamp** — the register limit of the model;
* **gain** — only this fraction of the optimum is applied (feedback %);
* **no harm** — a correction never moves a dimension measured in tolerance out of it;
* **dead band** — when every change is within it the verdict is *hold*;
* **EWMA** — deviations smoothed over consecutive reports (λ), reset on a tool change.

:func:`setupfix.pose.pose_problem` applies the rules that shape the problem (EWMA,
guard band, cumulative limit, costs) and :func:`recommend` those after
the solve, returning a :class:`Recommendation` with its verdict and the list of rules
that changed it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from setupfix.errors import Note
from setupfix.objective import error_budget, margins
from setupfix.optimize import CorrectionProblem, OptimizeResult

if TYPE_CHECKING:  # pose builds the problem with these rules; recommend takes what it built
    from setupfix.pose import PosedProblem

__all__ = ["RuleEffect", "Policy", "Recommendation", "reject_mask", "guard_limits", "cumulative_bounds",
           "apply_gain", "harmed_mask", "no_harm_floor",
           "in_dead_band", "ewma", "ewma_series", "Smoothed", "ewma_history", "recommend",
           "budget", "VERDICTS"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: The three verdicts, in order of severity.
VERDICTS = ("apply", "hold", "reject")


@dataclass(frozen=True)
class RuleEffect:
    """One rule that changed the recommendation, with what it changed."""

    rule: str
    message: str
    registers: tuple[str, ...] = ()
    dimensions: tuple[str, ...] = ()

    def to_json(self) -> dict[str, object]:
        return {"rule": self.rule, "message": self.message, "registers": list(self.registers),
                "dimensions": list(self.dimensions)}


@dataclass(frozen=True)
class Policy:
    """The safety settings aligned with one :class:`CorrectionProblem`.

    Attributes
    ----------
    dead_band, gain, cumulative_limit, cumulative, cost : ndarray of shape (n_registers,)
        Dead band [unit], gain in (0, 1], bound on |cumulative + change| [unit] (inf: off),
        change applied since the last reset [unit], least-norm weight (> 0).
    reject_band, uncertainty : ndarray of shape (n_dimensions,)
        Reject band beyond each limit [unit]; expanded uncertainty U [unit].
    guard_band : float
        Fraction of U by which each limit is shrunk.
    """

    dead_band: Array
    gain: Array
    cumulative_limit: Array
    cumulative: Array
    cost: Array
    reject_band: Array
    uncertainty: Array
    guard_band: float = 1.0

    @classmethod
    def neutral(cls, problem: CorrectionProblem) -> Policy:
        """No rule active: dead band 0, gain 1, no limits but the problem's, reject band ∞."""
        n, m = problem.n_registers, problem.deviation.shape[0]
        return cls(dead_band=np.zeros(n), gain=np.ones(n), cumulative_limit=np.full(n, np.inf),
                   cumulative=np.zeros(n), cost=np.ones(n), reject_band=np.full(m, np.inf),
                   uncertainty=np.zeros(m))


@dataclass
class Recommendation:
    """What to do with one measured cycle.

    Attributes
    ----------
    verdict : {"apply", "hold", "reject"}
    x : ndarray of shape (n_registers,) [unit]
        The changes to apply (all zero unless the verdict is ``apply``).
    result : OptimizeResult
        The optimiser's result on the guarded problem (x = 0 when rejected).
    problem : CorrectionProblem
        The guarded problem actually solved (limits shrunk, bounds tightened).
    rules : tuple of RuleEffect
        Every rule that changed the recommendation.
    given_up : tuple of str
        Dimensions no setup correction brings into tolerance (need the NC program).
    at_limit : tuple of str
        Registers whose change sits at a bound (per-step clamp or cumulative limit).
    alarm : str
        One sentence for the operator when the verdict is ``reject`` (else empty).
    """

    verdict: str
    x: Array
    result: OptimizeResult
    problem: CorrectionProblem
    rules: tuple[RuleEffect, ...] = ()
    given_up: tuple[str, ...] = ()
    at_limit: tuple[str, ...] = ()
    alarm: str = ""


def reject_mask(deviation: Array, lower: Array, upper: Array, band: Array) -> Mask:
    """Dimensions beyond a limit by more than the reject band.

    deviation, lower, upper, band : ndarray of shape (n_dimensions,) [unit]
    → bool ndarray of shape (n_dimensions,)
    """
    return (deviation < lower - band) | (deviation > upper + band)


def guard_limits(lower: Array, upper: Array, uncertainty: Array, fraction: float = 1.0) -> tuple[Array, Array]:
    """Tolerance limits shrunk by ``fraction · U`` at each end (ISO 14253-1 conformance zone).

    Where the zone would vanish (2gU ≥ upper − lower), both limits become the
    mid-tolerance, so the margin measures the distance to the centre (negative).

    Returns
    -------
    lower, upper : ndarrays of shape (n_dimensions,) [unit]
    """
    g = fraction * np.asarray(uncertainty, dtype=float)
    lo, up = lower + g, upper - g
    mid = (lower + upper) / 2
    crossed = lo > up
    return np.where(crossed, mid, lo), np.where(crossed, mid, up)


def cumulative_bounds(lb: Array, ub: Array, cumulative: Array, limit: Array, resolution: float) -> tuple[Array, Array]:
    """Step bounds that keep |cumulative + change| ≤ limit, snapped inwards on the grid.

    A register already beyond its cumulative limit may only move back: its bound on
    the far side becomes 0.  lb, ub, cumulative, limit : shape (n_registers,) [unit].
    """
    h = resolution
    lo = np.maximum(lb, np.ceil((-limit - cumulative) / h - 1e-9) * h)
    hi = np.minimum(ub, np.floor((limit - cumulative) / h + 1e-9) * h)
    lo = np.where(np.isfinite(limit), np.minimum(lo, 0.0), lb)
    hi = np.where(np.isfinite(limit), np.maximum(hi, 0.0), ub)
    # A register pushed beyond its bounds by both sides collapses to "no change".
    return np.where(lo > hi, 0.0, lo), np.where(lo > hi, 0.0, hi)


def apply_gain(x: Array, gain: Array, resolution: float) -> Array:
    """Feedback fraction of the changes, rounded towards zero onto the grid.

    Rounding towards zero keeps gain·x between 0 and x register by register, so a
    dimension inside its limits at x = 0 and at x stays inside (margins are concave).
    """
    steps = np.trunc(np.asarray(gain) * x / resolution + np.sign(x) * 1e-9)
    return steps * resolution + 0.0


def harmed_mask(deviation: Array, predicted: Array, lower: Array, upper: Array) -> Mask:
    """Dimensions measured in tolerance and predicted out of tolerance after a change."""
    inside_before = (deviation >= lower) & (deviation <= upper)
    inside_after = (predicted >= lower - 1e-12) & (predicted <= upper + 1e-12)
    return inside_before & ~inside_after


def in_dead_band(x: Array, dead_band: Array) -> bool:
    """True when every change is within its register's dead band (|x_j| ≤ band_j)."""
    return bool(np.all(np.abs(x) <= dead_band + 1e-12))


def ewma(measured: Array, previous: Array | None, lam: float) -> Array:
    """Exponentially weighted mean of deviations over reports: λ·y + (1 − λ)·previous.

    ``previous`` is the smoothed deviation of the last report shifted by the changes
    applied since (None after a reset or for the first report: y itself).
    Shapes (n_dimensions,) [unit]; NaN in ``previous`` falls back to y.
    """
    if previous is None or lam >= 1.0:
        return np.asarray(measured, dtype=float).copy()
    prev = np.where(np.isfinite(previous), previous, measured)
    return lam * measured + (1.0 - lam) * prev


def ewma_series(history: Array, lam: float) -> Array:
    """EWMA over reports in time order, the last row the current report.

    history : ndarray of shape (n_reports, n_dimensions) [unit]
        Deviations of earlier reports, each already shifted by the corrections
        applied since it was machined; NaN where a dimension was not measured or was
        reset (a tool change since: its earlier values no longer apply).
    lam : float
        λ in (0, 1]; a_k = λ·y_k + (1 − λ)·a_{k−1}, starting from the first value.

    Returns
    -------
    ndarray of shape (n_dimensions,)
    """
    a = np.full(history.shape[1], np.nan)
    for row in np.asarray(history, dtype=float):
        seen = ~np.isnan(row)
        a = np.where(seen, np.where(np.isnan(a), row, lam * row + (1.0 - lam) * a), a)
    return a


@dataclass(frozen=True, eq=False)
class Smoothed:
    """The EWMA estimate of one cycle's deviations (step 2).

    Attributes
    ----------
    deviation : ndarray of shape (n_dimensions,) [unit]
        Model order, NaN where the cycle did not measure the dimension.
    used : int
        Earlier parts that entered the estimate (0: the estimate is the measurement).
    lam : float
        λ of the smoothing.
    notes : tuple of Note
        Why nothing was smoothed (no timestamp …).
    """

    deviation: Array
    used: int
    lam: float
    notes: tuple[Note, ...] = ()


def ewma_history(deviation: Array, now: np.datetime64 | None, times: npt.NDArray[np.datetime64], earlier: Array,
                 log_times: npt.NDArray[np.datetime64], log_register: npt.NDArray[np.int64], log_delta: Array,
                 log_reset: Mask, composite: Array, lam: float, *, limit: int = 50) -> Smoothed:
    """EWMA of a cycle's deviations over the earlier parts, each shifted to the machine as it is now.

    An earlier part's deviation y_k becomes y_k + Σ Δx·C over the corrections logged
    after it was machined and up to ``now`` (eqs. 3–4), NaN on the dimensions a tool
    changed since cuts (its wear restarted); then a_k = λ·y_k + (1 − λ)·a_{k−1}
    (:func:`setupfix.safety.ewma_series`), the last row the current cycle.

    Parameters
    ----------
    deviation : ndarray of shape (n_dimensions,)
        The cycle as measured (NaN where not measured).
    now : datetime64 or None
        When the cycle was machined; None: nothing is smoothed.
    times, earlier : ndarrays of shapes (n_parts,), (n_parts, n_dimensions)
        Earlier parts (any order; only those before ``now`` count, the last ``limit``).
    log_times, log_register, log_delta, log_reset : ndarrays of shape (n_log,)
        Corrections log: time, register index (−1: not in the model), change, tool change.
    composite : ndarray of shape (n_registers, n_dimensions)
    lam : float in (0, 1]
    """
    if lam >= 1.0 or now is None:
        return Smoothed(deviation, 0, lam)
    before = np.flatnonzero(times < now)
    if before.size == 0:
        return Smoothed(deviation, 0, lam)
    before = before[np.argsort(times[before], kind="stable")][-limit:]
    rows = []
    known = log_register >= 0
    for k in before:
        t = times[k]
        since = known & (log_times > t) & (log_times <= now)
        reset = np.zeros(composite.shape[1], dtype=bool)
        shift = np.zeros(composite.shape[0])
        for j, delta, tool_change in zip(log_register[since], log_delta[since], log_reset[since], strict=True):
            if tool_change:
                reset |= composite[j] != 0
            elif np.isfinite(delta):
                shift[j] += delta
        row = earlier[k] + shift @ composite
        row[reset] = np.nan
        rows.append(row)
    rows.append(deviation)
    smoothed = ewma_series(np.vstack(rows), lam)
    return Smoothed(np.where(np.isnan(deviation), np.nan, smoothed), int(before.size), lam)


def _zero_result(problem: CorrectionProblem, optimizer: str, status: str, message: str) -> OptimizeResult:
    x = np.zeros(problem.n_registers)
    budget = problem.margin_before
    return OptimizeResult(x=x, margin_before=budget, margin_after=budget, norm=0.0, optimizer=optimizer,
                          evaluations=0, seconds=0.0, status=status, message=message,
                          binding=problem.binding(x))


def no_harm_floor(deviation: Array, lower: Array, upper: Array, guarded_lower: Array, guarded_upper: Array) -> Array:
    """No-harm floor of the guarded problem: a dimension measured inside its real limits keeps
    a guarded margin ≥ −(the guard band's shrink), i.e. stays inside the real limits.

    deviation, lower, upper : ndarray of shape (n_dimensions,) [unit]
        The (estimated) deviations and the real limits.
    guarded_lower, guarded_upper : ndarray of shape (n_dimensions,) [unit]
        The limits shrunk by :func:`guard_limits`.

    Returns
    -------
    ndarray of shape (n_dimensions,) [unit]
        −shrink (≤ 0; the smaller shrink of the two sides) where measured inside, −inf elsewhere
        (:attr:`setupfix.optimize.CorrectionProblem.floor`).
    """
    with np.errstate(invalid="ignore"):
        low = np.where(np.isfinite(lower), guarded_lower - lower, np.inf)
        high = np.where(np.isfinite(upper), upper - guarded_upper, np.inf)
    shrink = np.minimum(low, high)
    shrink = np.where(np.isfinite(shrink), np.maximum(shrink, 0.0), 0.0)
    inside = (deviation >= lower) & (deviation <= upper)
    return np.where(inside, -shrink, -np.inf)


def _inside(values: Array, lower: Array, upper: Array) -> Mask:
    return (values >= lower - 1e-12) & (values <= upper + 1e-12)


def recommend(posed: PosedProblem, solve: Callable[[CorrectionProblem], OptimizeResult], *,
              optimizer: str = "exact", names: Mapping[str, str] | None = None) -> Recommendation:
    """The rules after the solve, around ``solve(posed.guarded)``.

    Order: reject band (on the part as measured: no solve at all) → solve → gain →
    no harm (the triage's refusal; any harmful answer refused: nothing changed) → given up
    (read from the result) → dead band → clamp report.  The pre-solve rules
    (``posed.effects``) head the rule list.

    Parameters
    ----------
    posed : PosedProblem
    solve : callable
        ``solve(problem) -> OptimizeResult`` (any optimiser).
    names : mapping, optional
        Dimension ID → name, for the messages.
    """
    shown = names or {}

    def label(ids: Iterable[str]) -> str:
        return ", ".join(shown.get(i, i) for i in ids)

    problem, guarded, policy = posed.problem, posed.guarded, posed.policy
    ids = np.array(problem.register_ids, dtype=object)
    dims = np.array(problem.dimension_ids, dtype=object)
    dev, lower, upper = problem.deviation, problem.lower, problem.upper

    bad = reject_mask(posed.measured, lower, upper, policy.reject_band)
    if bad.any():
        bad_ids = tuple(dims[bad])
        alarm = (f"REJECT: {label(bad_ids)} beyond the reject band (a broken tool, a bad measurement or a wrong "
                 "part?) — no correction; check the part and the measurement")
        rules = [e for e in posed.effects if e.rule in ("ewma", "forecast")]
        rules.append(RuleEffect("reject", "deviation beyond the reject band: no correction", dimensions=bad_ids))
        result = _zero_result(problem, optimizer, "rejected", alarm)
        return Recommendation("reject", result.x, result, problem, tuple(rules), alarm=alarm)

    rules = list(posed.effects)
    result = solve(guarded)
    x = np.asarray(result.x, dtype=float)
    given_up = tuple(result.given_up)

    xg = apply_gain(x, policy.gain, problem.resolution)
    if np.any(xg != x):
        rules.append(RuleEffect("gain", "only the feedback fraction of the optimum is applied",
                                registers=tuple(ids[xg != x])))
    x = xg

    # no harm: the exact triage keeps every dimension measured in tolerance in it inside its optimum
    # (CorrectionProblem.floor); this checks the answer of any optimiser and refuses a harmful one
    triaged = result.extra.get("triage")
    if isinstance(triaged, dict) and triaged.get("refused"):
        rules.append(RuleEffect("no_harm", "not even the dimensions measured in tolerance can all be kept in it "
                                "within the register limits: nothing changed"))
        x = np.zeros_like(x)
    harmed = harmed_mask(dev, problem.predicted(x), lower, upper)
    if harmed.any():
        kept = tuple(dims[harmed])
        rules.append(RuleEffect("no_harm", f"the correction would move {label(kept)} (measured in tolerance) out "
                                "of it: nothing changed", dimensions=kept))
        x = np.zeros_like(x)
        given_up = ()
    elif given_up and isinstance(triaged, dict) and triaged.get("held"):
        rules.append(RuleEffect("no_harm", f"the triage kept the {triaged['held']} dimension(s) measured in "
                                "tolerance in it and gave up only what no such correction brings in"))
    out_after = ~_inside(problem.predicted(x), lower, upper)  # read from the answer applied (gain included)
    given_up = tuple(d for d, out in zip(dims, out_after, strict=True) if out and d in set(given_up))
    if given_up:
        rules.append(RuleEffect("given_up", "no setup correction brings these into tolerance: they need the NC "
                                "program or the process", dimensions=given_up))

    verdict = "apply"
    if not np.any(x):
        verdict = "hold"
    elif in_dead_band(x, policy.dead_band):
        rules.append(RuleEffect("dead_band", "every change is within its dead band: hold",
                                registers=tuple(ids[x != 0])))
        x = np.zeros_like(x)
        verdict = "hold"

    at = (x != 0) & ((x >= guarded.ub - 1e-12) | (x <= guarded.lb + 1e-12))
    at_limit = tuple(ids[at])
    if at_limit:
        rules.append(RuleEffect("clamp", "change at the register's per-step or cumulative limit",
                                registers=at_limit))
    return Recommendation(verdict, x + 0.0, result, guarded, tuple(rules), given_up, at_limit)


def budget(problem: CorrectionProblem, x: Array, given_up: tuple[str, ...] = ()) -> tuple[float, Array]:
    """Error budget and per-dimension margins of ``x`` on the real limits of ``problem``.

    The budget is over the dimensions not in ``given_up`` (the triage's: the headline δ is that of
    the dimensions kept); the margins are every dimension's.
    """
    m = margins(problem.predicted(x), problem.lower, problem.upper)
    if given_up:
        return problem.kept_margin(x, given_up), m
    return float(error_budget(problem.predicted(x), problem.lower, problem.upper)), m
