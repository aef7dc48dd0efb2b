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
from setupfix.explain import fit_registers, leave_one_out, targets
from setupfix.objective import error_budget, margins
from setupfix.optimize import CorrectionProblem, OptimizeResult

if TYPE_CHECKING:  # pose builds the problem with these rules; recommend takes what it built
    from setupfix.pose import PosedProblem

__all__ = ["RuleEffect", "Policy", "Recommendation", "reject_mask", "guard_limits", "cumulative_bounds",
           "apply_gain", "harmed_mask", "no_harm_floor", "in_dead_band", "ewma", "ewma_series", "Smoothed",
           "ewma_history", "recommend", "budget", "VERDICTS", "STOPPED", "short_list", "shifted_history",
           "last_measured"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: The three verdicts, in order of severity.
VERDICTS = ("apply", "hold", "reject")

#: Optimiser statuses of a solve stopped before its answer was proved (time limit, solver failure).
STOPPED = ("time_limit", "solver_error")

#: Names an alarm or a rule message lists before "… and N more" (the full list is in the rule's dimensions).
SHOWN = 3


def short_list(names: Iterable[str], shown: int = SHOWN) -> str:
    """The first ``shown`` names and how many more: ``"A, B, C, … and 741 more"`` (one line for any length)."""
    items = list(names)
    if len(items) <= shown + 1:
        return ", ".join(items)
    return ", ".join(items[:shown]) + f", … and {len(items) - shown} more"


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
    solved : bool
        False when the solve was stopped (status in :data:`STOPPED`: time limit, solver
        error) and nothing is recommended (verdict ``hold``): the hold then means "not
        solved within the time limit", never "no change needed"; the rule ``not_solved``
        says so.  A stopped solve that still yields a correction (checked better than none,
        e.g. the grid optimum proved but not the least norm) is ``apply`` with the rule
        ``stopped`` stating what is certified (``result.extra["norm_ratio_max"]``).
    """

    verdict: str
    x: Array
    result: OptimizeResult
    problem: CorrectionProblem
    rules: tuple[RuleEffect, ...] = ()
    given_up: tuple[str, ...] = ()
    at_limit: tuple[str, ...] = ()
    alarm: str = ""
    solved: bool = True


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
    rows = shifted_history(now, times, earlier, log_times, log_register, log_delta, log_reset, composite, limit)
    if rows.shape[0] == 0:
        return Smoothed(deviation, 0, lam)
    smoothed = ewma_series(np.vstack([rows, deviation]), lam)
    return Smoothed(np.where(np.isnan(deviation), np.nan, smoothed), int(rows.shape[0]), lam)


def shifted_history(now: np.datetime64, times: npt.NDArray[np.datetime64], earlier: Array,
                    log_times: npt.NDArray[np.datetime64], log_register: npt.NDArray[np.int64], log_delta: Array,
                    log_reset: Mask, composite: Array, limit: int = 50) -> Array:
    """The last ``limit`` parts machined before ``now``, oldest first, each moved to the machine as it is now.

    y_k + Σ Δx·C over the corrections logged after part k and up to ``now`` (eqs. 3–4);
    NaN where a tool changed since cuts the dimension (its wear restarted) or where the
    part did not measure it.  Arguments as :func:`ewma_history`.

    Returns
    -------
    ndarray of shape (n_before, n_dimensions) [unit]
    """
    before = np.flatnonzero(times < now)
    before = before[np.argsort(times[before], kind="stable")][-limit:] if before.size else before
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
    return np.vstack(rows) if rows else np.zeros((0, composite.shape[1]))


def last_measured(rows: Array) -> Array:
    """Each dimension's most recent value in ``rows`` (oldest first; NaN where none): the coverage stand-in.

    rows : ndarray of shape (n_parts, n_dimensions) → ndarray of shape (n_dimensions,)
    """
    out = np.full(rows.shape[1], np.nan)
    for row in rows:
        out = np.where(np.isnan(row), out, row)
    return out


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
              optimizer: str = "exact", names: Mapping[str, str] | None = None,
              registers: Mapping[str, str] | None = None, unit: str = "") -> Recommendation:
    """The rules after the solve, around ``solve(posed.guarded)``.

    Order: reject band (on the part as measured: no solve at all; :func:`beyond_band`
    tells gross deviations from setup errors) → solve → gain → no harm (the triage's
    refusal; any harmful answer refused: nothing changed) → given up (read from the
    result) → dead band → clamp report → stopped solve (:func:`stopped_rule`).  The
    pre-solve rules (``posed.effects``) head the rule list.  Lists of names in messages
    are short (:func:`short_list`); the rules' ``dimensions`` hold them all.

    Parameters
    ----------
    posed : PosedProblem
    solve : callable
        ``solve(problem) -> OptimizeResult`` (any optimiser).
    names : mapping, optional
        Dimension ID → name, for the messages.
    registers : mapping, optional
        Register ID → controller register (``G55``), for the messages.
    unit : str
        Length unit, for the messages.
    """
    shown = names or {}

    def label(ids: Iterable[str]) -> str:
        return short_list(shown.get(i, i) for i in ids)

    problem, guarded, policy = posed.problem, posed.guarded, posed.policy
    ids = np.array(problem.register_ids, dtype=object)
    dims = np.array(problem.dimension_ids, dtype=object)
    dev, lower, upper = problem.deviation, problem.lower, problem.upper

    bad = reject_mask(posed.measured, lower, upper, policy.reject_band)
    if bad.any():
        stop = beyond_band(posed, bad, optimizer, label, registers or {}, unit)
        if stop is not None:
            return stop

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
    solved = True
    if result.status in STOPPED:
        stopped = stopped_rule(result, recommended=verdict == "apply")
        rules.append(stopped)
        solved = stopped.rule != "not_solved"
    return Recommendation(verdict, x + 0.0, result, guarded, tuple(rules), given_up, at_limit, solved=solved)


def stopped_rule(result: OptimizeResult, *, recommended: bool) -> RuleEffect:
    """The rule of a solve stopped before its proof (``result.status`` in :data:`STOPPED`).

    ``not_solved`` when nothing is recommended: "not solved within the time limit" (or
    "the solver failed"), naming the stage; ``stopped`` when a correction is still
    recommended: what was proved and the certified bound on the norm
    (``result.extra["norm_ratio_max"]``: ‖x‖²_cost ≤ ratio · least norm).
    """
    where = result.extra.get("stopped")
    stage = where.get("stage", "") if isinstance(where, dict) else ""
    reason = where.get("reason", "") if isinstance(where, dict) else ""
    at = f" (the {stage} stage stopped)" if stage else ""
    if not recommended:
        what = ("not solved within the time limit" if result.status == "time_limit"
                else f"not solved: the solver failed{f' ({reason})' if reason else ''}")
        return RuleEffect("not_solved", f"{what}{at}: no proven correction, nothing is recommended (this is not "
                          "'no change needed'); allow more time (--time-limit) or check the model")
    ratio = result.extra.get("norm_ratio_max")
    certified = []
    if stage != "least norm" and result.bound is not None and np.isfinite(result.bound):
        certified.append(f"the error budget {result.margin_after:+.4f} is within "
                         f"{max(result.bound - result.margin_after, 0.0):.4f} of the best possible (LP bound "
                         f"{result.bound:+.4f})")
    if isinstance(ratio, float) and np.isfinite(ratio):
        certified.append(f"the correction's weighted norm is at most {ratio:.3f}× the least norm")
    first = "solve stopped by the time limit" if result.status == "time_limit" else "solve stopped by a solver error"
    return RuleEffect("stopped", f"{first}{at}: {result.message}"
                      + (f"; certified: {' and '.join(certified)}" if certified else ""))


def beyond_band(posed: PosedProblem, bad: Mask, optimizer: str, label: Callable[[Iterable[str]], str],
                registers: Mapping[str, str], unit: str) -> Recommendation | None:
    """The decision on a part with deviations beyond the reject band (``bad``), before any solve.

    * **gross** — a deviation whose residual after the best correction of the *other*
      dimensions (:func:`setupfix.explain.leave_one_out`) is still beyond the reject band:
      nothing the setup does explains it (a broken tool, a bad measurement, a wrong
      part): verdict ``reject``, rule ``reject`` naming every such dimension;
    * **setup error** — the others explain it (a register entered wrong: a whole station
      shifted): the registers fitted to the dimensions that are not gross
      (:func:`setupfix.explain.fit_registers`) are named where the change they need is
      beyond their per-step limit (a fixed register: any change), in the rule
      ``setup_error`` (``registers``: their IDs), e.g. "G55 looks off by −0.350 mm;
      beyond the per-step limit 0.1".  The documented rule: **hold** — no register is
      changed, the alarm names the register and the amount to check; a wrong entry is
      corrected by the operator at the control, not stepped off by the per-step limit
      over several parts (each of them scrap).  With gross deviations as well the verdict
      is ``reject`` and the setup error is named beside them;
    * explained within the registers' limits: None — the solve corrects it.
    """
    problem, policy = posed.problem, posed.policy
    ids = np.array(problem.register_ids, dtype=object)
    dims = np.array(problem.dimension_ids, dtype=object)
    lower, upper = problem.lower, problem.upper
    goal = targets(lower, upper)
    residual = posed.measured - goal
    gross = bad & reject_mask(goal + leave_one_out(problem.composite, residual), lower, upper, policy.reject_band)
    explained = bad & ~gross
    setup: RuleEffect | None = None
    if explained.any():
        x = fit_registers(problem.composite, residual, ~gross)
        h = problem.resolution
        moves = np.any(problem.composite[:, explained] != 0, axis=1)
        fixed = problem.ub <= problem.lb
        over = moves & ((x > problem.ub + h / 2) | (x < problem.lb - h / 2)) & (np.abs(x) >= h)
        if over.any():
            digits = max(0, int(-np.floor(np.log10(h) + 1e-9)))
            parts = [f"{registers.get(r, r)} looks off by {v:+.{digits}f}{f' {unit}' if unit else ''}; "
                     + ("fixed in the model" if f else f"beyond the per-step limit {max(abs(lo), hi):g}")
                     for r, v, lo, hi, f in zip(ids[over], x[over], problem.lb[over], problem.ub[over],
                                                fixed[over], strict=True)]
            setup = RuleEffect("setup_error", "; ".join(parts) + f" (it explains {label(dims[explained])}): a "
                               "register entered wrong? no correction — check it at the control",
                               registers=tuple(ids[over]), dimensions=tuple(dims[explained]))
    rules = [e for e in posed.effects if e.rule in ("ewma", "forecast")]
    if gross.any():
        gross_ids = tuple(dims[gross])
        alarm = (f"REJECT: {len(gross_ids)} dimension(s) beyond the reject band that no setup correction explains: "
                 f"{label(gross_ids)} (a broken tool, a bad measurement or a wrong part?) — no correction; check "
                 "the part and the measurement")
        if setup is not None:
            alarm += f"; also {setup.message.split(' (it explains')[0]}"
        rules.append(RuleEffect("reject", "deviation beyond the reject band, not explained by any setup "
                                "correction: no correction", dimensions=gross_ids))
        rules += [setup] if setup is not None else []
        result = _zero_result(problem, optimizer, "rejected", alarm)
        return Recommendation("reject", result.x, result, problem, tuple(rules), alarm=alarm)
    if setup is None:
        return None
    alarm = f"SETUP ERROR: {setup.message}"
    result = _zero_result(problem, optimizer, "setup_error", alarm)
    return Recommendation("hold", result.x, result, posed.guarded, (*rules, setup), alarm=alarm)


def budget(problem: CorrectionProblem, x: Array, given_up: tuple[str, ...] = ()) -> tuple[float, Array]:
    """Error budget and per-dimension margins of ``x`` on the real limits of ``problem``.

    The budget is over the dimensions not in ``given_up`` (the triage's: the headline δ is that of
    the dimensions kept); the margins are every dimension's.
    """
    m = margins(problem.predicted(x), problem.lower, problem.upper)
    if given_up:
        return problem.kept_margin(x, given_up), m
    return float(error_budget(problem.predicted(x), problem.lower, problem.upper)), m
