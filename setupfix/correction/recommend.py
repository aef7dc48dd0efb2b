"""The rules after the solve: from an optimum to a recommendation with its verdict.

Order (:func:`recommend`): a draft model (``[process] draft = true``, an unedited
``model init`` scaffold) holds before anything else (:func:`draft_hold`: nothing is
solved); then the reject band on the part as measured (:func:`beyond_band` tells
gross deviations from setup errors; no solve at all) → solve → gain → no harm → given up
(read from the answer) → dead band → clamp report → stopped solve (:func:`stopped_rule`).
The rules that shape the problem before the solve are :func:`setupfix.correction.pose.pose_problem`'s;
the rules' data and vectorised pieces are :mod:`setupfix.correction.safety`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from setupfix.correction.conformance import conformance_zone
from setupfix.correction.explain import fit_registers, leave_one_out, one_register, targets
from setupfix.correction.numbers import fmt
from setupfix.correction.objective import error_budget, margins
from setupfix.correction.rules import dimension_changes, within_share_band
from setupfix.correction.safety import (
    STOPPED,
    Recommendation,
    RuleEffect,
    apply_gain,
    in_dead_band,
    reject_mask,
    short_list,
)
from setupfix.optimize import CorrectionProblem, OptimizeResult, Status, harmed_columns

if TYPE_CHECKING:  # pose builds the problem with the rules; recommend takes what it built
    from setupfix.correction.pose import PosedProblem

__all__ = [
    "recommend",
    "no_zone_left",
    "stopped_rule",
    "stopped_where",
    "verdict_cell",
    "beyond_band",
    "budget",
    "draft_hold",
    "DRAFT_KEY",
]

#: The key of a draft model, as the user removes it: ``[process] draft = true``.
DRAFT_KEY = "draft = true"

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


def _zero_result(problem: CorrectionProblem, optimizer: str, status: Status, message: str) -> OptimizeResult:
    x = np.zeros(problem.n_registers)
    budget = problem.margin_before
    return OptimizeResult(
        x=x,
        margin_before=budget,
        margin_after=budget,
        norm=0.0,
        optimizer=optimizer,
        evaluations=0,
        seconds=0.0,
        status=status,
        message=message,
        binding=problem.binding(x),
    )


def _inside(values: Array, lower: Array, upper: Array) -> Mask:
    return (values >= lower - 1e-12) & (values <= upper + 1e-12)


def recommend(
    posed: PosedProblem,
    solve: Callable[[CorrectionProblem], OptimizeResult],
    *,
    optimizer: str = "exact",
    names: Mapping[str, str] | None = None,
    registers: Mapping[str, str] | None = None,
    unit: str = "",
    draft: str | None = None,
) -> Recommendation:
    """The rules after the solve, around ``solve(posed.guarded)``.

    A draft model (``draft``: its file) holds before any rule or solve (:func:`draft_hold`).

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
    draft : str, optional
        The model file when the model is a draft (``ProcessModel.draft``): hold with the
        rule ``draft``, nothing solved.
    """
    if draft is not None:
        return draft_hold(posed, draft, optimizer)
    shown = names or {}

    def label(ids: Iterable[str]) -> str:
        return short_list(shown.get(i, i) for i in ids)

    problem, guarded, policy = posed.problem, posed.guarded, posed.policy
    ids = np.array(problem.register_ids, dtype=object)
    dims = np.array(problem.dimension_ids, dtype=object)
    lower, upper = problem.lower, problem.upper

    bad = reject_mask(posed.measured, lower, upper, policy.reject_band)
    if bad.any():
        stop = beyond_band(posed, bad, optimizer, label, registers or {}, unit)
        if stop is not None:
            return stop

    rules = list(posed.effects)
    empty = no_zone_left(problem.lower, problem.upper, policy.uncertainty * policy.guard_band)
    if empty.any():
        rules.append(
            RuleEffect(
                "no_conformance_zone",
                f"U leaves {label(dims[empty])} no conformance zone (ISO 14253-1): nothing there can be proven "
                "conforming; the correction centres them in their tolerance",
                dimensions=tuple(dims[empty]),
            )
        )
    result = solve(guarded)
    x = np.asarray(result.x, dtype=float)
    given_up = tuple(result.given_up)

    xg = apply_gain(x, policy.gain, problem.resolution)
    if np.any(xg != x):
        rules.append(
            RuleEffect("gain", "only the feedback fraction of the optimum is applied", registers=tuple(ids[xg != x]))
        )
    x = xg

    # no harm: the exact triage keeps every dimension measured in tolerance in it inside its optimum
    # (CorrectionProblem.floor); this checks the answer of any optimiser and refuses a harmful one
    triaged = result.triage
    if triaged is not None and triaged.refused:
        rules.append(
            RuleEffect(
                "no_harm",
                "not even the dimensions measured in tolerance can all be kept in it "
                "within the register limits: nothing changed",
            )
        )
        x = np.zeros_like(x)
    harmed = harmed_columns(problem, x)  # a position zone as a whole, never facet by facet
    if harmed.any():
        kept = tuple(dims[harmed])
        rules.append(
            RuleEffect(
                "no_harm",
                f"the correction would move {label(kept)} (measured in tolerance) out of it: nothing changed",
                dimensions=kept,
            )
        )
        x = np.zeros_like(x)
        given_up = ()
    elif given_up and triaged is not None and triaged.held:
        rules.append(
            RuleEffect(
                "no_harm",
                f"the triage kept the {triaged.held} dimension(s) measured in "
                "tolerance in it and gave up only what no such correction brings in",
            )
        )
    out_after = ~_inside(problem.predicted(x), lower, upper)  # read from the answer applied (gain included)
    given_up = tuple(d for d, out in zip(dims, out_after, strict=True) if out and d in set(given_up))
    if given_up:
        rules.append(
            RuleEffect(
                "given_up",
                "no setup correction brings these into tolerance: they need the NC program or the process",
                dimensions=given_up,
            )
        )

    verdict = "apply"
    stopped = result.status in STOPPED
    small = bool(np.any(x)) and in_dead_band(x, policy.dead_band)
    share = (
        bool(np.any(x))
        and not small
        and policy.dimension_band is not None
        and within_share_band(dimension_changes(problem, x)[1], policy.dimension_band)
    )
    if not np.any(x):
        verdict = "hold"
    elif (small or share) and stopped:  # an unproven point's small changes prove nothing
        x = np.zeros_like(x)
        verdict = "hold"
    elif small:
        rules.append(
            RuleEffect("dead_band", "every change is within its dead band: hold", registers=tuple(ids[x != 0]))
        )
        x = np.zeros_like(x)
        verdict = "hold"
    elif share:
        rules.append(
            RuleEffect(
                "dead_band",
                "no dimension's predicted change exceeds its dead band (a share of its tolerance width): hold",
                registers=tuple(ids[x != 0]),
            )
        )
        x = np.zeros_like(x)
        verdict = "hold"

    at = (x != 0) & ((x >= guarded.ub - 1e-12) | (x <= guarded.lb + 1e-12))
    at_limit = tuple(ids[at])
    if at_limit:
        rules.append(RuleEffect("clamp", "change at the register's per-step or cumulative limit", registers=at_limit))
    solved = True
    if stopped:
        effect = stopped_rule(result, recommended=verdict == "apply")
        rules.append(effect)
        solved = effect.rule != "not_solved"
    return Recommendation(verdict, x + 0.0, result, guarded, tuple(rules), given_up, at_limit, solved=solved)


def no_zone_left(lower: Array, upper: Array, shrink: Array) -> Mask:
    """Columns whose guard band leaves no conformance zone: 2·g·U ≥ upper − lower (g·U > 0).

    :func:`setupfix.correction.safety.guard_limits` then puts both guarded limits at the
    mid-tolerance, so the optimum centres them: the documented fallback.
    lower, upper, shrink : ndarray of shape (n_dimensions,) [unit] → bool ndarray (n_dimensions,)
    """
    return conformance_zone(lower, upper, np.asarray(shrink, dtype=float))[2]


def stopped_where(result: OptimizeResult) -> str:
    """Where and why a solve stopped before its proof (``"work limit in the leximin stage"``); empty for a
    proved solve (or one never run: a draft, a reject)."""
    if result.status not in STOPPED or result.stopped is None:
        return ""
    return f"{result.stopped.reason} in the {result.stopped.stage} stage"


def verdict_cell(rec: Recommendation) -> str:
    """The verdict as a file's cell says it (the offsets CSV, batch's progress): ``apply``, ``hold``,
    ``reject``; a stopped solve is never a plain one: ``not solved (time limit in the lp bound stage)``
    (nothing proven, every delta 0) or ``apply (stopped: work limit in the leximin stage)``."""
    return verdict_text(rec.verdict, rec.solved, stopped_where(rec.result))


def verdict_text(verdict: str, solved: bool, where: str) -> str:
    """:func:`verdict_cell` from its parts (a stored recommendation's JSON has them): the verdict word,
    whether anything was proven, and :func:`stopped_where`'s text ("" for a proved solve)."""
    if not solved:
        return f"not solved ({where})" if where else "not solved"
    return f"{verdict} (stopped: {where})" if where else verdict


def draft_hold(posed: PosedProblem, model_file: str, optimizer: str = "exact") -> Recommendation:
    """The decision on any part corrected with a draft model: **hold**, every change 0, nothing solved.

    A draft is a scaffold ``setupfix model init`` wrote from the reports: its relations
    (which registers move which feature, with which weight) are a guess until the user
    has checked them, and a correction from guessed physics is worse than none.  The
    rule ``draft`` and the alarm name the model file and the key to remove; the verdict
    is ``hold`` (the hold conventions: exit status 0, an alarm on stderr, offsets of 0).
    """
    message = (
        f"edit the model (draft): {model_file} is a scaffold whose relations are a guess; check which "
        f"registers move which feature and with which weight, then remove '{DRAFT_KEY}' from its [process] "
        "table"
    )
    result = _zero_result(posed.problem, optimizer, "draft", f"hold: {message}")
    return Recommendation(
        "hold", result.x, result, posed.guarded, (RuleEffect("draft", message),), alarm=f"DRAFT MODEL: {message}"
    )


def stopped_rule(result: OptimizeResult, *, recommended: bool) -> RuleEffect:
    """The rule of a solve stopped before its proof (``result.status`` in :data:`STOPPED`).

    ``not_solved`` when nothing is recommended: "not solved within the time limit" (the
    wall-clock guard: the exact optimiser then gives no correction at all), "… within the work
    limit" (the solver settings' work budget) or "the solver failed", naming the stage;
    ``stopped`` when a correction is still recommended (a work-limit stop, the same under any
    load): what was proved and the certified bound on the norm (``result.norm_ratio_max``:
    ‖x‖²_cost ≤ ratio · least norm).
    """
    where = result.stopped
    stage = where.stage if where is not None else ""
    reason = where.reason if where is not None else ""
    at = f" (the {stage} stage stopped)" if stage else ""
    limit = "work limit" if reason == "work limit" else "time limit"
    if not recommended:
        what = (
            f"not solved within the {limit}"
            if result.status == "time_limit"
            else f"not solved: the solver failed{f' ({reason})' if reason else ''}"
        )
        advice = "allow more time (--time-limit) or check the model" if limit == "time limit" else "check the model"
        return RuleEffect(
            "not_solved",
            f"{what}{at}: no proven correction, nothing is recommended (this is not 'no change needed'); {advice}",
        )
    ratio = result.norm_ratio_max
    certified = []
    if stage != "least norm" and result.bound is not None and np.isfinite(result.bound):
        certified.append(
            f"the error budget {fmt(result.margin_after, 4, sign=True)} is within "
            f"{fmt(max(result.bound - result.margin_after, 0.0), 4)} of the best possible (LP bound "
            f"{fmt(result.bound, 4, sign=True)})"
        )
    if isinstance(ratio, float) and np.isfinite(ratio):
        certified.append(f"the correction's weighted norm is at most {ratio:.3f}× the least norm")
    first = f"solve stopped by the {limit}" if result.status == "time_limit" else "solve stopped by a solver error"
    return RuleEffect(
        "stopped", f"{first}{at}: {result.message}" + (f"; certified: {' and '.join(certified)}" if certified else "")
    )


def beyond_band(
    posed: PosedProblem,
    bad: Mask,
    optimizer: str,
    label: Callable[[Iterable[str]], str],
    registers: Mapping[str, str],
    unit: str,
) -> Recommendation | None:
    """The decision on a part with deviations beyond the reject band (``bad``), before any solve.

    * **gross** — a deviation whose residual after the best correction of the *other*
      dimensions (:func:`setupfix.correction.explain.leave_one_out`) is still beyond the reject band:
      nothing the setup does explains it (a broken tool, a bad measurement, a wrong
      part): verdict ``reject``, rule ``reject`` naming every such dimension;
    * **setup error** — the others explain it (a register entered wrong: a whole station
      shifted): the registers fitted to the dimensions that are not gross
      (:func:`setupfix.correction.explain.fit_registers`) are named where the change they need is
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
        j, change, after = one_register(problem.composite, residual, ~gross)
        if j >= 0 and not reject_mask(goal + after, lower, upper, policy.reject_band)[explained].any():
            x = np.zeros_like(x)  # one register alone explains them: name it, not the fit's spread over many
            x[j] = change
        h = problem.resolution
        moves = np.any(problem.composite[:, explained] != 0, axis=1)
        fixed = problem.ub <= problem.lb
        over = moves & ((x > problem.ub + h / 2) | (x < problem.lb - h / 2)) & (np.abs(x) >= h)
        if over.any():
            digits = max(0, int(-np.floor(np.log10(h) + 1e-9)))
            parts = [
                f"{registers.get(r, r)} looks off by {fmt(v, digits, sign=True)}{f' {unit}' if unit else ''}; "
                + ("fixed in the model" if f else f"beyond the per-step limit {max(abs(lo), hi):g}")
                for r, v, lo, hi, f in zip(
                    ids[over], x[over], problem.lb[over], problem.ub[over], fixed[over], strict=True
                )
            ]
            setup = RuleEffect(
                "setup_error",
                "; ".join(parts) + f" (it explains {label(dims[explained])}): a "
                "register entered wrong? no correction — check it at the control",
                registers=tuple(ids[over]),
                dimensions=tuple(dims[explained]),
            )
    rules = [e for e in posed.effects if e.rule in ("ewma", "forecast")]
    if gross.any():
        gross_ids = tuple(dims[gross])
        alarm = (
            f"REJECT: {len(gross_ids)} dimension(s) beyond the reject band that no setup correction explains: "
            f"{label(gross_ids)} (a broken tool, a bad measurement or a wrong part?) — no correction; check "
            "the part and the measurement"
        )
        if setup is not None:
            alarm += f"; also {setup.message.split(' (it explains')[0]}"
        rules.append(
            RuleEffect(
                "reject",
                "deviation beyond the reject band, not explained by any setup correction: no correction",
                dimensions=gross_ids,
            )
        )
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
