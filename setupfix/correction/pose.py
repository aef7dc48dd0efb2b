"""Posing the correction problem of one measured cycle: the one builder, in one documented order.

Every door (``correct``, batch, the TUI, ``compare``, the diagnosis's next correction)
solves the problem :func:`pose_problem` builds, and :func:`setupfix.correction.recommend.recommend`
applies the rules that act after the solve.  The order, each step on the output of the one before:

1. **measurements** — the cycle's deviations y (model order, NaN where not measured);
   only measured dimensions enter the problem (eqs. 3–4: predicted = y + x·C);
   **coverage** — a dimension absent from the report is stood in for by its recent
   measurement from the history, moved by the corrections applied since (``stand_in``,
   :meth:`setupfix.inputs.smoothing.History.stand_in`), and then enters the problem
   like a measured one; without one, every register that moves it is held at 0 (rule
   ``coverage``, naming registers and dimensions) — a correction never moves what was
   not measured — unless the model marks the dimension ``sampled = true`` (not measured
   every cycle: a sampling plan), which leaves its registers free as before;
2. **smoothing** — the EWMA estimate ŷ of the deviations over the earlier parts
   (λ of ``[safety] ewma``; :func:`setupfix.correction.ewma.ewma_history`, arrays from the history);
3. **effects forecast** — the model's ``[effects]`` drift and wear until the next cycle
   are added (:func:`setupfix.diagnose.forecast.forecast_shift`); its relations (or a
   composite given by the caller, e.g. the diagnosis's augmented matrix) replace C;
4. **guard band** — each tolerance limit shrunk by g·U (ISO 14253-1); the error budget
   f1 (eq. 8) of the guarded problem is a proven margin;
5. **cumulative bounds** — step bounds tightened so |applied since reset + x| stays
   within the cumulative limit;
6. **costs** — the registers' least-norm weights (f2 = Σ cost·x², eq. 9 weighted;
   the exact optimiser's second stage, f = 10·f1 − f2 of eq. 10 with unit costs);
7. **fixed registers** — bounds (0, 0), also for the registers coverage holds.

:class:`PosedProblem` keeps the problem on the real limits (for every number shown),
the guarded problem (what is solved), the policy of the rules after the solve, the
as-measured deviations (the reject band judges the part as measured) and the
pre-solve :class:`~setupfix.correction.safety.RuleEffect` list.  Pure: arrays in and out, no files.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from parsers.timestamps import instant
from setupfix.core.errors import Note, SourceLocation
from setupfix.correction.ewma import Smoothed
from setupfix.correction.relation import relation_matrices
from setupfix.correction.safety import Policy, RuleEffect, cumulative_bounds, guard_limits, no_harm_floor, short_list
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.optimize import CorrectionProblem

__all__ = [
    "PosedProblem",
    "forecast_of",
    "effects_composite",
    "policy_of",
    "pose_problem",
    "pose_policy",
    "coverage",
    "hours_between",
]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


def hours_between(stamp: str, origin: str, where: str) -> float:
    """Hours from ``origin`` to ``stamp`` (ISO 8601, read by :func:`parsers.timestamps.instant`:
    aware times compared in UTC).

    Raises
    ------
    ParseError
        If either is not an ISO 8601 time (named with ``where``).
    """
    place = SourceLocation(where)
    return (instant(stamp, place) - instant(origin, place)).total_seconds() / 3600.0


def forecast_of(model: ProcessModel, timestamp: str | None, report: str = "") -> tuple[Array, Note | None]:
    """Step 3: change of every dimension from the measured cycle to the next, by ``model.effects``.

    Drift goes on for one cycle interval, every tool wears one more cycle
    (:func:`setupfix.diagnose.forecast.forecast_shift`).  Returns zeros and no note
    when the model has no drift or wear effect.

    Returns
    -------
    shift : ndarray of shape (n_dimensions,) [unit]
    note : Note or None
    """
    section = model.effects
    if not any(e.kind in ("drift", "wear") for e in section.effects):
        return np.zeros(len(model.dimensions)), None
    # Imported here: the diagnosis brings scipy.stats (~0.5 s of start-up) a model without effects never needs.
    from setupfix.diagnose.forecast import forecast_shift
    from setupfix.diagnose.terms import Layout

    time = hours_between(timestamp, section.origin, report) if section.origin and timestamp else None
    shift = forecast_shift(section, Layout.from_model(model), time=time)
    kinds = sorted({e.kind for e in section.effects if e.kind in ("drift", "wear")})
    note = Note(
        f"the model's [effects] ({', '.join(kinds)}) forecast the next cycle: up to "
        f"{np.max(np.abs(shift)):.4f} {model.unit} added to the measured deviations",
        SourceLocation(model.source, key="effects"),
        "forecast",
    )
    return shift, note


def effects_composite(model: ProcessModel) -> tuple[Array | None, Note | None]:
    """Step 3: the composite C with the model's ``[effects]`` relations (None when they change nothing).

    See :func:`setupfix.diagnose.forecast.relation_composite`: C + Σ δ e_i e_qᵀ for a
    named register whose weight is known to a third.

    Returns
    -------
    composite : ndarray of shape (n_registers, n_dimensions) or None
    note : Note or None
    """
    section = model.effects
    if not any(e.kind == "relation" for e in section.effects):
        return None, None
    from setupfix.diagnose.forecast import relation_composite  # lazy: see forecast_of
    from setupfix.diagnose.terms import Layout

    layout = Layout.from_model(model)
    C = relation_composite(section, layout)
    changed = np.argwhere(layout.composite != C)
    if changed.size == 0:
        return None, None
    what = ", ".join(
        f"{layout.dimension_ids[q]} ~ {layout.register_ids[i]} {layout.composite[i, q]:g} → {C[i, q]:.4g}"
        for i, q in changed
    )
    note = Note(
        f"the model's [effects] relation(s) map the correction: {what}",
        SourceLocation(model.source, key="effects"),
        "relation",
    )
    return C, note


def policy_of(
    model: ProcessModel, dimension_ids: tuple[str, ...], cumulative: Mapping[str, float] | None = None
) -> Policy:
    """The model's safety settings as arrays aligned with the problem's dimensions (defaults filled in).

    ``cumulative`` gives, by register ID, the change applied since the last reset
    (the current wear value of a wear register); the cumulative limit applies to
    those registers only, since for the others the total is not known.
    """
    s = model.safety
    regs = [r.policy for r in model.registers]
    band = s.dead_band if s.dead_band is not None else 2 * model.resolution
    # A rotation component lives on the problem's grid scaled by h/ρ (CorrectionProblem.scale): its
    # applied total is scaled alike, its dead band is two of its steps, it has no cumulative limit.
    scale = np.array([model.resolution_of(r) / model.resolution for r in model.registers])
    rotation = np.array([r.component == "C" for r in model.registers], dtype=bool)
    dims = {d.id: d for d in model.dimensions}
    width = np.array([dims[d].upper - dims[d].lower for d in dimension_ids])
    reject = np.array(
        [
            s.dimension_reject_band.get(d, s.reject_band if s.reject_band is not None else w)
            for d, w in zip(dimension_ids, width, strict=True)
        ],
        dtype=float,
    )
    cum_limit = [p.cumulative_limit if p.cumulative_limit is not None else s.cumulative_limit for p in regs]
    return Policy(
        dead_band=np.where(
            rotation,
            2 * model.resolution,
            np.array([p.dead_band if p.dead_band is not None else band for p in regs], dtype=float),
        ),
        gain=np.array([p.gain if p.gain is not None else s.gain for p in regs], dtype=float),
        cumulative_limit=np.array(
            [
                np.inf if c is None or r.id not in (cumulative or {}) or r.component == "C" else c
                for c, r in zip(cum_limit, model.registers, strict=True)
            ],
            dtype=float,
        ),
        cumulative=np.array([float((cumulative or {}).get(r.id, 0.0)) for r in model.registers]) / scale,
        cost=np.array([p.cost for p in regs], dtype=float),
        reject_band=np.nan_to_num(reject, nan=np.inf, posinf=np.inf),
        uncertainty=np.array([s.dimension_uncertainty.get(d, s.uncertainty) for d in dimension_ids], dtype=float),
        guard_band=s.guard_band,
    )


@dataclass(frozen=True, eq=False)
class PosedProblem:
    """The problem of one cycle, posed (module docstring), ready for any optimiser.

    Attributes
    ----------
    problem : CorrectionProblem
        On the real tolerance limits with the estimated deviations (smoothed,
        forecast), the effective composite and the register costs.
    guarded : CorrectionProblem
        What is solved: limits shrunk by the guard band, bounds by the cumulative
        limit, fixed registers at (0, 0).
    policy : Policy
        The settings of the rules (those after the solve: reject band, gain, no harm,
        dead band, clamp).
    measured : ndarray of shape (n_dimensions,) [unit]
        The measured dimensions' deviations as the report gives them (reject band).
    effects : tuple of RuleEffect
        The pre-solve rules that changed the problem (ewma, forecast, guard_band,
        cumulative_limit), in the order applied.
    notes : tuple of Note
        What the steps assumed (forecast, relations, smoothing not possible …).
    """

    problem: CorrectionProblem
    guarded: CorrectionProblem
    policy: Policy
    measured: Array
    effects: tuple[RuleEffect, ...] = ()
    notes: tuple[Note, ...] = ()

    @property
    def estimated(self) -> bool:
        """True when the problem's deviations are an estimate (smoothed or forecast), not the report's."""
        return any(e.rule in ("ewma", "forecast") for e in self.effects)


def pose_policy(
    problem: CorrectionProblem,
    policy: Policy,
    *,
    measured: Array | None = None,
    effects: tuple[RuleEffect, ...] = (),
    notes: tuple[Note, ...] = (),
    held: Mask | None = None,
) -> PosedProblem:
    """Steps 4–7 on a problem already holding its deviations and composite (steps 1–3).

    Parameters
    ----------
    problem : CorrectionProblem
        Real limits; register limits as bounds.
    policy : Policy
        Aligned with ``problem``.
    measured : ndarray of shape (n_dimensions,), optional
        The report's own deviations when ``problem.deviation`` is an estimate.
    effects, notes
        What steps 1–3 did (prepended to the rule list).
    held : bool ndarray of shape (n_registers,), optional
        Registers held at 0 in the guarded problem (coverage, step 1).
    """
    dims = np.array(problem.dimension_ids, dtype=object)
    ids = np.array(problem.register_ids, dtype=object)
    rules = list(effects)
    guarded = problem
    if np.any(policy.uncertainty > 0):  # 4. guard band
        lo, up = guard_limits(problem.lower, problem.upper, policy.uncertainty, policy.guard_band)
        floor = no_harm_floor(problem.deviation, problem.lower, problem.upper, lo, up)  # no harm on the real limits
        guarded = dataclasses.replace(guarded, lower=lo, upper=up, floor=floor)
        shrunk = tuple(dims[policy.uncertainty > 0])
        rules.append(
            RuleEffect(
                "guard_band",
                f"limits of {len(shrunk)} dimension(s) shrunk by {policy.guard_band:g}·U (ISO 14253-1)",
                dimensions=shrunk,
            )
        )
    lb, ub = problem.lb, problem.ub
    if np.any(np.isfinite(policy.cumulative_limit)):  # 5. cumulative bounds
        lb, ub = cumulative_bounds(lb, ub, policy.cumulative, policy.cumulative_limit, problem.resolution)
        tightened = (lb > problem.lb) | (ub < problem.ub)
        if tightened.any():
            rules.append(
                RuleEffect(
                    "cumulative_limit",
                    "step bounds tightened so that the total since the last reset stays within the cumulative limit",
                    registers=tuple(ids[tightened]),
                )
            )
    cost = np.asarray(policy.cost, dtype=float)  # 6. costs
    fixed = problem.ub <= problem.lb  # 7. fixed registers (and registers without room) …
    if held is not None:
        fixed = fixed | held  # … and those coverage holds
    lb, ub = np.where(fixed, 0.0, lb), np.where(fixed, 0.0, ub)
    if not (np.array_equal(lb, guarded.lb) and np.array_equal(ub, guarded.ub) and np.array_equal(cost, guarded.cost)):
        guarded = dataclasses.replace(guarded, lb=lb, ub=ub, cost=cost)
    raw = problem.deviation if measured is None else np.asarray(measured, dtype=float)
    return PosedProblem(problem, guarded, policy, raw, tuple(rules), notes)


def coverage(
    model: ProcessModel, part: PartMeasurement, composite: Array | None = None, stand_in: Array | None = None
) -> tuple[PartMeasurement, Mask, list[RuleEffect]]:
    """Step 1's coverage: the part with stand-ins for absent dimensions, the registers held at 0, the rules.

    Parameters
    ----------
    composite : ndarray of shape (n_registers, n_dimensions), optional
        C over every dimension (default the model's).
    stand_in : ndarray of shape (n_dimensions,), optional
        A recent measurement of each dimension moved to the machine as it is now (NaN: none).

    Returns
    -------
    part : PartMeasurement
        With the stand-ins in place of NaN (they are then measured for the problem).
    held : bool ndarray of shape (n_registers,)
    rules : list of RuleEffect
        ``stand_in`` and ``coverage`` where they changed anything.
    """
    absent = ~part.measured
    is_zone = np.array([d.zone for d in model.dimensions], dtype=bool)
    if part.zone is not None and is_zone.any():  # a zone is measured only with both its components
        absent = absent | (is_zone & np.isnan(part.zone).any(axis=1))
    rules: list[RuleEffect] = []
    if not absent.any():
        return part, np.zeros(len(model.registers), dtype=bool), rules
    rel = relation_matrices(model)
    composite = rel.composite if composite is None else np.asarray(composite, dtype=float)
    if rel.zones is not None:  # a zone's column of C is zero: its components' columns say what moves it
        composite = composite + np.abs(rel.zones).sum(axis=2)
    ids = np.array([d.id for d in model.dimensions], dtype=object)
    names = {d.id: d.name for d in model.dimensions}
    if stand_in is not None:
        stands = absent & np.isfinite(stand_in) & ~is_zone  # a radial distance alone cannot stand in for a zone
        if stands.any():
            part = dataclasses.replace(part, deviation=np.where(stands, stand_in, part.deviation))
            absent = absent & ~stands
            rules.append(
                RuleEffect(
                    "stand_in",
                    f"{int(stands.sum())} dimension(s) absent from the report stood in "
                    f"for by their last measurement in the history, moved by the corrections "
                    f"applied since: {short_list(names[d] for d in ids[stands])}",
                    dimensions=tuple(ids[stands]),
                )
            )
    sampled = np.array([d.sampled for d in model.dimensions], dtype=bool)
    blind = absent & ~sampled
    held = np.any(composite[:, blind] != 0, axis=1)
    if held.any():
        regs = tuple(r.id for r, h in zip(model.registers, held, strict=True) if h)
        shown = short_list(r.register for r, h in zip(model.registers, held, strict=True) if h)
        rules.append(
            RuleEffect(
                "coverage",
                f"{shown} held at 0: they move {int(blind.sum())} dimension(s) absent "
                f"from the report ({short_list(names[d] for d in ids[blind])}) with no recent "
                "measurement in the history; a correction never moves what was not measured "
                "(mark a dimension not measured every cycle with sampled = true)",
                registers=regs,
                dimensions=tuple(ids[blind]),
            )
        )
    return part, held, rules


def pose_problem(
    model: ProcessModel,
    part: PartMeasurement,
    *,
    smoothed: Smoothed | None = None,
    cumulative: Mapping[str, float] | None = None,
    composite: Array | None = None,
    policy: Policy | None = None,
    stand_in: Array | None = None,
    hold: RuleEffect | None = None,
) -> PosedProblem:
    """Pose the problem of one measured cycle in the module's order (steps 1–7).

    Parameters
    ----------
    model : ProcessModel
    part : PartMeasurement
        The cycle as measured (step 1).
    smoothed : Smoothed, optional
        Its EWMA estimate (step 2), from the history (:func:`setupfix.correction.ewma.ewma_history`).
    cumulative : mapping register ID → float, optional
        Change applied since the last reset (the current value of wear registers, step 5).
    composite : ndarray of shape (n_registers, n_dimensions), optional
        A relation matrix replacing C (the diagnosis's augmented one); default the
        model's, with its ``[effects]`` relations (step 3).
    policy : Policy, optional
        Settings replacing the model's (tests, what-if); default :func:`policy_of`.
    stand_in : ndarray of shape (n_dimensions,), optional
        Recent measurements from the history standing in for absent dimensions (coverage,
        step 1; NaN where none).
    hold : RuleEffect, optional
        A caller's rule holding its ``registers`` at 0 (step 7, fixed registers; the
        diagnosis's centre rule), named in the rule list.
    """
    held_part, held, effects = coverage(model, part, composite, stand_in)
    if hold is not None and hold.registers:
        held = held | np.array([r.id in hold.registers for r in model.registers], dtype=bool)
        effects.append(hold)
    if held_part is not part:  # stood-in dimensions are measured for the problem (and the smoothing skips them)
        part = held_part
        if smoothed is not None:
            smoothed = dataclasses.replace(
                smoothed, deviation=np.where(np.isnan(smoothed.deviation), part.deviation, smoothed.deviation)
            )
    if composite is None:  # 3. effects: relations (replacing C)
        composite, note = effects_composite(model)
        relation_note = note
    else:
        relation_note = None
    raw = CorrectionProblem.from_part(model, part, composite)
    keep = part.measured
    measured = raw.deviation
    deviation = part.deviation
    notes: list[Note] = list(smoothed.notes) if smoothed is not None else []
    dim_ids = tuple(d.id for d, k in zip(model.dimensions, keep, strict=True) if k)
    if smoothed is not None and smoothed.used:  # 2. smoothing
        deviation = smoothed.deviation
        effects.append(
            RuleEffect(
                "ewma",
                f"deviations smoothed over {smoothed.used} earlier part(s), λ = {smoothed.lam:g}",
                dimensions=dim_ids,
            )
        )
    shift, note = forecast_of(model, part.timestamp, part.report)  # 3. effects: forecast …
    if note is not None:
        deviation = deviation + shift
        notes.append(note)
        moved = tuple(d for d, v in zip(dim_ids, shift[keep], strict=True) if v != 0)
        effects.append(
            RuleEffect(
                "forecast",
                "deviations forecast to the next cycle by the model's [effects] (drift, wear)",
                dimensions=moved,
            )
        )
    problem = (
        raw
        if deviation is part.deviation
        else CorrectionProblem.from_part(model, dataclasses.replace(part, deviation=deviation), composite)
    )
    if relation_note is not None:
        notes.append(relation_note)
    if problem.circles is not None and deviation is not part.deviation:
        notes.append(
            Note(
                "position zones are corrected on their components as measured (the smoothing and the "
                "forecast act on the other dimensions only)",
                None,
                "zone",
            )
        )
    if problem.polygon > 0:
        notes.append(
            Note(
                f"position zones solved on inscribed polygons: their margins are within "
                f"{problem.polygon:.2g} {model.unit} of the circle's (every margin shown is the circle's)",
                SourceLocation(model.source, key="dimensions"),
                "zone",
            )
        )
    policy = policy if policy is not None else policy_of(model, problem.rows or problem.dimension_ids, cumulative)
    return pose_policy(
        problem,
        policy,
        measured=measured,
        effects=tuple(effects),
        notes=tuple(notes),
        held=held if held.any() else None,
    )
