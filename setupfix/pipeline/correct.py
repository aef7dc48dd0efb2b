"""Use case "correct": from a process model and a CMM report to register corrections.

Shared by ``setupfix correct``, batch processing and the TUI.  The steps are
load the model → read the report (any supported format) → tie characteristics to
dimensions (part by part, stations merged into fixture cycles) → pose the
problem → optimise → a :class:`PartCorrection` per cycle.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from setupfix.errors import ExportError, MatchError, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, load_model
from setupfix.model.effects import model_effects
from setupfix.model.safety import safety_settings
from setupfix.offsets import OffsetRow, offset_rows
from setupfix.pipeline.controllers import read_current, write_offsets
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.pipeline.cycles import Stations, assign_stations, load_parts  # noqa: F401 - re-exported
from setupfix.pipeline.smoothing import smooth_part
from setupfix.safety import Policy, Recommendation, RuleEffect, budget, recommend
from setupfix.store import Store

__all__ = ["PartCorrection", "safety_policy", "assign_stations", "load_parts", "select_parts", "correct_part", "correct_report",
           "write_correction_offsets", "open_history", "applied_result",
           "wear_totals"]


@dataclass
class PartCorrection:
    """The recommendation for one measured cycle and everything needed to show it.

    ``result`` is the optimiser's answer on the guarded problem; ``recommendation``
    what the safety rules made of it (verdict, applied changes, rules).  Every
    number shown (predicted, margins, budgets) is for the applied changes on the
    real tolerance limits.
    """

    model: ProcessModel
    part: PartMeasurement
    problem: CorrectionProblem
    result: OptimizeResult
    recommendation: Recommendation
    warnings: list[str] = field(default_factory=list)
    measured: np.ndarray | None = None  #: the report's own deviations when ``problem`` holds smoothed/forecast ones

    @property
    def verdict(self) -> str:
        return self.recommendation.verdict

    @property
    def x(self) -> np.ndarray:
        """Applied changes of every register (model order), zero unless the verdict is apply."""
        return self.recommendation.x

    #: Thermal feed-forward step (``correct --thermal``), set by setupfix.pipeline.feedforward.apply_feed_forward.
    thermal: Any = None

    @property
    def corrections(self) -> dict[str, float]:
        """Correction of every correctable register by model ID, zero included (thermal feed-forward added
        unless the verdict is reject)."""
        out = {rid: float(v) for rid, v, reg in zip(self.problem.register_ids, self.x,
                                                    self.model.registers) if not reg.fixed}
        if self.thermal is not None and self.verdict != "reject":
            for rid, shift in self.thermal.corrections().items():
                out[rid] = out.get(rid, 0.0) + shift
        return out

    @property
    def margin_before(self) -> float:
        return self.problem.margin_before

    @property
    def margin_after(self) -> float:
        return budget(self.problem, self.x)[0]

    @property
    def norm(self) -> float:
        return float(np.linalg.norm(self.x))

    @property
    def binding(self) -> tuple[str, ...]:
        """The dimensions that stop a better correction (none when rejected)."""
        return self.result.binding

    def register_rows(self) -> list[dict[str, Any]]:
        """Every register, fixed ones included: id, register, kind, offset, delta, fixed, at_limit."""
        at = set(self.recommendation.at_limit)
        rows = []
        for reg, delta in zip(self.model.registers, self.x):
            policy = safety_settings(self.model).register(reg.id)
            rows.append({"id": reg.id, "register": reg.register, "kind": reg.kind,
                         "offset": policy.offset or ("wear" if reg.kind == "tool" else "geometry"),
                         "delta": float(delta), "fixed": reg.fixed, "at_limit": reg.id in at})
        return rows

    def dimension_rows(self) -> list[dict[str, Any]]:
        """Per measured dimension: id, name, deviation, limits, predicted, margin after, flags.

        ``flags`` lists ``out`` (predicted out of tolerance after the changes),
        ``out_before`` (measured out of tolerance), ``binding``, ``given_up``,
        ``rejected`` and ``guard`` (predicted inside the limits but within U of one).
        """
        dims = {d.id: d for d in self.model.dimensions}
        predicted = self.problem.predicted(self.x)
        margins = budget(self.problem, self.x)[1]
        binding, given_up = set(self.binding), set(self.recommendation.given_up)
        rejected = {d for r in self.recommendation.rules if r.rule == "reject" for d in r.dimensions}
        guard = self.recommendation.problem
        rows = []
        for i, did in enumerate(self.problem.dimension_ids):
            d = dims[did]
            flags = []
            if not d.lower <= self.problem.deviation[i] <= d.upper:
                flags.append("out_before")
            if margins[i] < -1e-12:
                flags.append("out")
            elif not guard.lower[i] - 1e-12 <= predicted[i] <= guard.upper[i] + 1e-12:
                flags.append("guard")
            if did in binding:
                flags.append("binding")
            if did in given_up:
                flags.append("given_up")
            if did in rejected:
                flags.append("rejected")
            row = {
                "id": did, "name": d.name, "station": d.group, "deviation": float(self.problem.deviation[i]),
                "predicted": float(predicted[i]), "lower": d.lower, "upper": d.upper,
                "margin": float(margins[i]), "flags": flags,
            }
            if self.measured is not None:  # smoothed or forecast: the estimate is what was corrected
                row["estimate"], row["deviation"] = row["deviation"], float(self.measured[i])
            rows.append(row)
        return rows

    def offsets(self, current: Mapping[str, float] | None = None) -> list[OffsetRow]:
        return offset_rows(self.model, self.corrections, report=self.part.report, part=self.part.part,
                           current=current, verdict=self.verdict)

    def to_json(self) -> dict[str, Any]:
        """The ``correct --json`` object of ``../shared/spec/cli-json.md`` (plus extra keys)."""
        digits = 9
        r = self.result
        names = {d.id: d.name for d in self.model.dimensions}
        rec = self.recommendation
        return {
            "part": self.part.part,
            "report": self.part.report,
            "verdict": rec.verdict,
            "alarm": rec.alarm or None,
            "optimizer": r.optimizer,
            "status": r.status,
            "margin_before": round(self.margin_before, digits),
            "margin_after": round(self.margin_after, digits),
            "bonus": round(self.margin_after - self.margin_before, digits),
            "norm": round(self.norm, digits),
            "bound": None if r.bound is None else round(r.bound, digits),
            "in_tolerance": self.margin_after >= 0,
            "message": r.message,
            "corrections": {k: round(v, digits) for k, v in self.corrections.items()},
            "registers": [{**row, "delta": round(row["delta"], digits)} for row in self.register_rows()],
            "binding": [names[b] for b in self.binding],
            "given_up": [names[b] for b in rec.given_up],
            "at_limit": list(rec.at_limit),
            "rules": [e.to_json() for e in rec.rules],
            "dimensions": [
                {k: (round(v, digits) if isinstance(v, float) and np.isfinite(v) else
                     (None if isinstance(v, float) else v))
                 for k, v in row.items()}
                for row in self.dimension_rows()
            ],
            "absent": list(self.part.absent),
            "unmatched": list(self.part.unmatched),
            "suggestions": {name: list(near) for name, near in self.part.suggestions.items()},
            "warnings": list(self.warnings),
            "evaluations": r.evaluations,
            "seconds": round(r.seconds, 6),
        } | ({"thermal": self.thermal.to_json()} if self.thermal is not None else {})


def applied_result(problem: CorrectionProblem, rec: Recommendation) -> OptimizeResult:
    """The optimiser's result restated for the changes actually recommended.

    ``x``, δ after, norm and binding dimensions are those of ``rec.x`` on the real
    tolerance limits (the raw optimum stays in ``rec.result``), so every reader of
    ``PartCorrection.result`` — tables, JSON, the TUI — shows what is to be applied.
    """
    raw = rec.result
    x = np.asarray(rec.x, dtype=float)
    if rec.verdict == "reject":
        binding: tuple[str, ...] = ()
    elif rec.verdict == "apply" and np.array_equal(x, raw.x) and raw.binding:
        binding = raw.binding
    else:
        binding = problem.binding(x)
    message = raw.message
    if rec.verdict == "hold":
        message = "hold: " + next((r.message for r in rec.rules if r.rule in ("dead_band", "no_harm")),
                                  "no change needed")
    return dataclasses.replace(raw, x=x.copy(), margin_before=problem.margin_before,
                               margin_after=budget(problem, x)[0], norm=float(np.linalg.norm(x)),
                               binding=binding, message=message)


def safety_policy(model: ProcessModel, problem: CorrectionProblem,
                  cumulative: Mapping[str, float] | None = None) -> Policy:
    """The model's safety settings as arrays aligned with ``problem`` (defaults filled in).

    ``cumulative`` gives, by register ID, the change applied since the last reset
    (the current wear value of a wear register); the cumulative limit applies to
    those registers only, since for the others the total is not known.
    """
    s = safety_settings(model)
    regs = [s.register(r.id) for r in model.registers]
    band = s.dead_band if s.dead_band is not None else 2 * model.resolution
    dims = {d.id: d for d in model.dimensions}
    width = np.array([dims[d].upper - dims[d].lower for d in problem.dimension_ids])
    reject = np.array([s.dimension_reject_band.get(d, s.reject_band if s.reject_band is not None else w)
                       for d, w in zip(problem.dimension_ids, width)], dtype=float)
    cum_limit = [p.cumulative_limit if p.cumulative_limit is not None else s.cumulative_limit for p in regs]
    return Policy(
        dead_band=np.array([p.dead_band if p.dead_band is not None else band for p in regs], dtype=float),
        gain=np.array([p.gain if p.gain is not None else s.gain for p in regs], dtype=float),
        # only where the total since the last reset is known (a wear register's current value)
        cumulative_limit=np.array([np.inf if c is None or r.id not in (cumulative or {}) else c
                                   for c, r in zip(cum_limit, model.registers)], dtype=float),
        cumulative=np.array([float((cumulative or {}).get(r.id, 0.0)) for r in model.registers]),
        cost=np.array([p.cost for p in regs], dtype=float),
        reject_band=np.nan_to_num(reject, nan=np.inf, posinf=np.inf),
        uncertainty=np.array([s.dimension_uncertainty.get(d, s.uncertainty) for d in problem.dimension_ids],
                             dtype=float),
        guard_band=s.guard_band,
    )


def correct_part(model: ProcessModel, part: PartMeasurement, *, optimizer: str = "exact",
                 seed: int | None = None, cumulative: Mapping[str, float] | None = None,
                 store: Store | None = None, **params: Any) -> PartCorrection:
    """Recommend the corrections of one measured cycle: optimum under the model's safety rules.

    ``cumulative`` (register ID → change applied since the last reset) feeds the
    cumulative limit; ``store`` (the history store) the EWMA smoothing when the
    model's ``ewma`` λ is below 1.
    """
    notes = [str(n) for n in part.notes]
    lam = safety_settings(model).ewma
    smoothed = None
    if lam < 1.0:
        if store is None:
            notes.append(f"ewma = {lam:g} needs the history store (--store): deviations not smoothed")
        else:
            smoothed = smooth_part(model, part, store, lam)
            if smoothed.note:
                notes.append(smoothed.note)
    measured_part = part
    if smoothed is not None and smoothed.used:
        part = dataclasses.replace(part, deviation=smoothed.deviation)
    effects = bool(model_effects(model).effects)
    if effects:
        # the model's [effects]: drift and wear until the next cycle.  Imported here: the diagnosis
        # brings scipy.stats (~0.5 s of start-up), which a model without effects never needs.
        from setupfix.pipeline.diagnose import forecast_part

        forecast = forecast_part(model, part)
        if forecast is not part:
            notes += [str(n) for n in forecast.notes[len(part.notes):]]
            part = forecast
    problem = CorrectionProblem.from_part(model, part)
    if effects:
        from setupfix.pipeline.diagnose import effect_relations

        problem, relation_note = effect_relations(model, problem, part)
        if relation_note is not None:  # the model's [effects] relations change what a correction does
            notes.append(str(relation_note))
    raw = measured_part.deviation[measured_part.measured] if part is not measured_part else None
    opt = get_optimizer(optimizer, seed=seed, **params)
    rec = recommend(problem, safety_policy(model, problem, cumulative), opt.solve, optimizer=optimizer,
                    names={d.id: d.name for d in model.dimensions}, measured=raw)
    if raw is not None and smoothed is not None:
        rec.rules = (RuleEffect("ewma", f"deviations smoothed over {smoothed.used} earlier part(s), λ = {lam:g}",
                                dimensions=problem.dimension_ids), *rec.rules)
    result = applied_result(problem, rec)
    notes += [str(n) for n in rec.result.notes if n.message != rec.result.message]
    part = measured_part
    if part.absent:
        notes.append(f"{len(part.absent)} dimension(s) absent from the report, left out: {', '.join(part.absent)}")
    if part.unmatched:
        notes.append(f"{len(part.unmatched)} characteristic(s) match no dimension: {', '.join(part.unmatched[:8])}"
                     + (" …" if len(part.unmatched) > 8 else ""))
    return PartCorrection(model=model, part=part, problem=problem, result=result, recommendation=rec, warnings=notes,
                          measured=raw)


def correct_report(model: ProcessModel | str | Path, report: str | Path, *, optimizer: str = "exact",
                   seed: int | None = None, part: str | None = None, format: str | None = None,
                   unit: str | None = None, encoding: str | None = None, columns: str | None = None,
                   stations: Stations | None = None, parts_per_cycle: int | None = None,
                   strict: bool = False, lenient: bool = False, store: Store | None = None,
                   current: Mapping[str, float] | None = None,
                   params: Mapping[str, Any] | None = None) -> list[PartCorrection]:
    """Correct every cycle of a report (or the one named by ``part``).

    ``store`` feeds the smoothing; ``current`` (the controller's current offsets by
    register ID) the cumulative limit of wear registers (see :func:`wear_totals`);
    ``params`` the optimiser's hyper-parameters (e.g. ``{"time_limit": 5.0}``).
    """
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    parts = load_parts(model, report, format=format, unit=unit, encoding=encoding, columns=columns,
                       stations=stations, parts_per_cycle=parts_per_cycle, strict=strict, lenient=lenient)
    cumulative = wear_totals(model, current) if current is not None else None
    return [correct_part(model, p, optimizer=optimizer, seed=seed, store=store, cumulative=cumulative,
                         **(params or {}))
            for p in select_parts(parts, part, report)]


def wear_totals(model: ProcessModel, current: Mapping[str, float]) -> dict[str, float]:
    """Change applied since the last reset of each wear register: its current value.

    A wear offset is set to 0 when the tool (or the setup) is renewed, so its value
    is the total of the corrections since; geometry registers have no such total.
    """
    settings = safety_settings(model)
    out = {}
    for reg in model.registers:
        offset = settings.register(reg.id).offset or ("wear" if reg.kind == "tool" else "geometry")
        if offset == "wear" and reg.id in current:
            out[reg.id] = float(current[reg.id])
    return out


def select_parts(parts: list[PartMeasurement], part: str | None, report: str | Path) -> list[PartMeasurement]:
    """All parts, or only the one named ``part``.

    Raises
    ------
    MatchError
        If no part of the report has that name (the message lists the names).
    """
    if part is None:
        return parts
    chosen = [p for p in parts if p.part == part]
    if not chosen:
        raise MatchError(f"no part {part!r} in the report (parts: {', '.join(p.part or '(none)' for p in parts)})",
                         location=SourceLocation(str(report)))
    return chosen


def write_correction_offsets(results: Sequence[PartCorrection], target: str, *, controller: str = "csv",
                             current: str | Path | Mapping[str, float] | None = None) -> None:
    """Write the offsets of ``results`` in a controller's syntax, atomically.

    ``current`` (the controller's current offsets, ``register,value``) makes the rows
    absolute (*set*).  A program (every format but csv) holds one correction.

    Raises
    ------
    ExportError
        If a controller program would hold several cycles, or a register cannot be
        expressed in the format; nothing is written then.
    ParseError
        If the current-offsets file is bad.
    """
    if not results:
        return
    model = results[0].model
    values = (current if isinstance(current, Mapping) else read_current(current, model)) if current is not None \
        else None
    if controller != "csv" and len(results) > 1:
        raise ExportError(f"{controller}: a program holds one correction, the report has {len(results)} cycles "
                          f"({', '.join(r.part.part or '—' for r in results)}): choose one with --part")
    rows = [row for r in results for row in r.offsets(values)]
    title = f"{results[0].part.report} {results[0].part.part}".strip()
    write_offsets(rows, target, controller=controller, title=title)


def open_history(path: str | Path) -> Store:
    """Open an existing history store (a missing file is an error, not a new empty store)."""
    from setupfix.store import open_store

    if not Path(path).is_file():
        raise ExportError("no history store here (import reports with 'setupfix history import')",
                          location=SourceLocation(str(path)))
    return open_store(path)
