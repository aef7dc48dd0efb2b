"""Use case "diagnose": a series of reports, the corrections log and temperatures → diagnosis.

Shared by ``setupfix diagnose``, the TUI and the benches.  Steps: load the model (and
its ``[effects]``) → the series (:mod:`setupfix.pipeline.series`: every report, one
cycle per machined part, with the corrections in effect, the parts cut since each tool
change and the temperatures) → the engine
(:class:`setupfix.diagnose.Diagnoser`) → the next correction (exact optimiser on the
forecast) → JSON per ``../shared/spec/cli-json.md`` and, with ``augment``, the model
with the effects found written as its ``[effects]`` section.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from setupfix.diagnose import Diagnoser, Diagnosis, Layout
from setupfix.diagnose.forecast import forecast_shift, relation_composite
from setupfix.diagnose.terms import typical_step
from setupfix.errors import ExportError, ModelError, Note, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, model_from_dict
from setupfix.model.effects import EffectsSection, ModelEffect, effects_from_dict, model_effects, with_effects
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.pipeline.series import (SeriesInput, corrections_from_table, expand_reports, hours_since, load_series,
                                      parse_times, read_corrections_log, read_temperature_log, report_coordinates,
                                      temperatures_from_table)
from setupfix.pipeline.writers import check_target, write_text

__all__ = ["SeriesInput", "DiagnoseOutcome", "load_series", "read_corrections_log", "read_temperature_log",
           "diagnose_reports", "expand_reports", "augmented_section", "write_augmented",
           "corrections_from_table", "temperatures_from_table", "forecast_part", "effect_relations", "report_coordinates"]

def augmented_section(diagnosis: Diagnosis, declared: EffectsSection) -> EffectsSection:
    """The ``[effects]`` section: the model's own effects, then those found (ids E1, E2, …)."""
    s = diagnosis.series
    step = typical_step(s.time) if s.n_cycles > 1 else None
    effects = list(declared.effects)
    used = {e.id for e in effects}
    n = 1
    for res in diagnosis.effects:
        while f"E{n}" in used:
            n += 1
        sp = res.spec
        target = sp.target
        if len(res.registers) > 1:  # the register is not named: the file must not pretend it is
            target = (f"{sp.dimension} ~ one of {', '.join(res.registers)} "
                      f"(the series cannot tell which; {sp.register} fitted)")
        effects.append(ModelEffect(
            id=f"E{n}", kind=sp.kind, estimate=float(f"{res.estimate:.6g}"), stderr=float(f"{res.stderr:.3g}"),
            unit=res.unit, target=target, shape=sp.shape, tau=sp.tau if sp.shape == "saturating" else None,
            channel=sp.channel, reference=sp.reference, register=sp.register, dimension=sp.dimension,
            axis=sp.axis, group=sp.group, registers=res.registers if len(res.registers) > 1 else ()))
        used.add(f"E{n}")
    return EffectsSection(tuple(effects), s.origin or declared.origin, step if step else declared.cycle_hours,
                          float(s.time[-1]) if s.n_cycles else declared.last_hours)


@dataclass
class DiagnoseOutcome:
    """A diagnosis with what the CLI and TUI show: next correction, notes, augmented file."""

    input: SeriesInput
    diagnosis: Diagnosis
    next_correction: dict[str, float]
    augmented: str | None = None
    notes: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """The ``diagnose --json`` object of ``../shared/spec/cli-json.md`` (plus extra keys)."""
        d = self.diagnosis
        lay = d.layout
        names = {dim.id: dim.name for dim in self.input.model.dimensions}

        def r(v: float, digits: int = 9) -> float | None:
            return round(float(v), digits) if math.isfinite(v) else None

        out: dict[str, Any] = {
            "cycles": d.series.n_cycles,
            "rms_before": r(d.error_before.rms), "rms_after": r(d.error_after.rms),
            "max_before": r(d.error_before.max), "max_after": r(d.error_after.max),
            "out_of_tolerance_before": d.error_before.out_of_tolerance,
            "out_of_tolerance_after": d.error_after.out_of_tolerance,
            "effects": [{"kind": e.kind, "target": e.target, "estimate": r(e.estimate, 12),
                         "stderr": r(e.stderr, 12), "unit": e.unit, "rms_after": r(e.rms_after),
                         "alike": list(e.alike),
                         **({"registers": list(e.registers)} if e.kind == "relation" else {})} for e in d.effects],
            "next_correction": {k: round(v, 9) for k, v in self.next_correction.items()},
            "declared_effects": [e.target for e in self.input.declared],
            "rejected": [{"kind": s.spec.kind, "target": s.spec.target, "p_adjusted": r(s.p_adjusted, 6),
                          "cv_before": r(s.cv_before), "cv_after": r(s.cv_after)}
                         for s in d.selection.steps if not s.accepted],
            "unidentifiable": list(d.selection.unidentifiable),
            "lack_of_fit": d.selection.lack_of_fit,
            "dimensions": [{"id": did, "name": names[did],
                            "rms_before": r(d.error_before.rms_by_dimension[q]),
                            "rms_after": r(d.error_after.rms_by_dimension[q]),
                            "max_before": r(d.error_before.max_by_dimension[q]),
                            "max_after": r(d.error_after.max_by_dimension[q]),
                            "forecast": r(d.forecast[q])}
                           for q, did in enumerate(lay.dimension_ids)],
            "per_cycle": [{"cycle": c, "rms_before": r(d.error_before.rms_by_cycle[k]),
                           "rms_after": r(d.error_after.rms_by_cycle[k]),
                           "max_before": r(d.error_before.max_by_cycle[k]),
                           "max_after": r(d.error_after.max_by_cycle[k])}
                          for k, c in enumerate(d.series.cycles)],
            "walk_forward": None if d.walk is None else {
                "cycles_scored": len(d.walk.cycles),
                **{name: {"mean_budget": r(b.mean_budget), "worst_budget": r(b.worst_budget), "rms": r(b.rms),
                          "out_of_tolerance": b.out_of_tolerance} for name, b in d.walk.budgets.items()}},
            "augmented": self.augmented,
            "notes": list(self.notes),
        }
        return out


def _next_correction(model: ProcessModel, diagnosis: Diagnosis) -> tuple[dict[str, float], list[str]]:
    """Exact optimum (max error budget, grid) on the forecast, through the augmented relations."""
    fc = diagnosis.forecast
    if not np.isfinite(fc).any():
        return {}, ["no forecast: nothing measured"]
    part = PartMeasurement(part="next", report="forecast", timestamp=None, deviation=fc,
                           sources=tuple("" for _ in fc))
    problem = CorrectionProblem.from_part(model, part)
    C_aug = diagnosis.relation_matrix()
    problem = dataclasses.replace(problem, composite=C_aug[:, part.measured])
    result = get_optimizer("exact").solve(problem)
    corr = {rid: float(v) for rid, v, reg in zip(problem.register_ids, result.x, model.registers) if not reg.fixed}
    return corr, []


def diagnose_reports(model: ProcessModel | str | Path, reports: Sequence[str | Path] = (), *,
                     corrections: str | None = None, temperatures: str | None = None, augment: str | None = None,
                     diagnoser: Diagnoser | None = None, db: str | Path | None = None,
                     thermal: str | Path | None = None, lenient: bool = False) -> DiagnoseOutcome:
    """Diagnose a series of reports; optionally write the augmented model.

    Raises
    ------
    SetupfixError
        Bad input (named with its place) or an augmented file that cannot be written;
        nothing is half-written.
    """
    if augment:
        check_target(augment)  # a bad target costs nothing
    inp = load_series(model, reports, corrections=corrections, temperatures=temperatures, db=db, thermal=thermal,
                      lenient=lenient)
    diagnoser = diagnoser or Diagnoser()
    diagnosis = diagnoser.run(inp.layout, inp.series, declared=inp.declared)
    nxt, more = _next_correction(inp.model, diagnosis)
    notes = list(inp.notes) + list(diagnosis.notes) + more
    out = DiagnoseOutcome(inp, diagnosis, nxt, None, notes)
    if db is not None:
        _record(db, inp.model, out)
    if augment:
        out.augmented = write_augmented(inp.model, augmented_section(diagnosis, inp.effects), augment)
    return out


def _record(db: str | Path, model: ProcessModel, out: DiagnoseOutcome) -> None:
    """Keep the recommended next correction in the history store, with what it was computed from."""
    import hashlib

    from setupfix.store import Recommendation, open_store

    doc = out.to_json()
    result = {k: doc[k] for k in ("cycles", "rms_before", "rms_after", "max_before", "max_after", "effects",
                                  "next_correction")}
    inputs: dict[str, Any] = {"command": "diagnose", "model": model.source,
                              "corrections": out.input.corrections, "temperatures": out.input.temperatures}
    if Path(model.source).is_file():
        inputs["model_sha256"] = hashlib.sha256(Path(model.source).read_bytes()).hexdigest()
    with open_store(db) as store, store.transaction():
        store.add_recommendation(Recommendation("exact", inputs, result))


def write_augmented(model: ProcessModel, section: EffectsSection, target: str) -> str:
    """Write the model file with ``section`` as its ``[effects]``; the text is reloaded first.

    Raises
    ------
    ExportError
        If the source model cannot be read or the target cannot be written.
    """
    try:
        text = Path(model.source).read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise ExportError(f"cannot read the model to augment: {exc.strerror}",
                          location=SourceLocation(model.source)) from None
    new = with_effects(text, section)
    try:  # what is written must load, model and effects
        doc = tomllib.loads(new)
        check = model_from_dict(doc, source=target)
        effects_from_dict(doc.get("effects"), check, target)
    except (tomllib.TOMLDecodeError, ModelError) as exc:
        raise ExportError(f"the augmented model would not load: {exc}", location=SourceLocation(target)) from None
    write_text(target, new)
    return target



def forecast_part(model: ProcessModel, part: PartMeasurement) -> PartMeasurement:
    """The part as the next cycle is expected to come out, by the model's ``[effects]``.

    ``correct`` optimises the next cycle, not the one measured: a drift goes on for
    one cycle interval and every tool wears one cycle more (see
    :func:`setupfix.diagnose.forecast.forecast_shift`).  A model without drift or wear
    effects returns the part unchanged.
    """
    section = model_effects(model)
    if not any(e.kind in ("drift", "wear") for e in section.effects):
        return part
    time = None
    if section.origin and part.timestamp:
        time = float(hours_since(parse_times([part.timestamp], part.report), pd.Timestamp(section.origin))[0])
    shift = forecast_shift(section, Layout.from_model(model), time=time)
    kinds = sorted({e.kind for e in section.effects if e.kind in ("drift", "wear")})
    note = Note(f"the model's [effects] ({', '.join(kinds)}) forecast the next cycle: up to "
                f"{np.max(np.abs(shift)):.4f} {model.unit} added to the measured deviations",
                SourceLocation(model.source, key="effects"), "forecast")
    return dataclasses.replace(part, deviation=part.deviation + shift, notes=(*part.notes, note))


def effect_relations(model: ProcessModel, problem: CorrectionProblem,
                     part: PartMeasurement) -> tuple[CorrectionProblem, Note | None]:
    """The problem with the corrections mapped through the model's ``[effects]`` relations.

    A relation found by ``diagnose`` says how a dimension really answers a register; the
    correction for the next cycle must be mapped through it (see
    :func:`setupfix.diagnose.forecast.relation_composite`: only a named register with a
    weight known to a third).  Without such a relation the problem is returned as is.
    """
    section = model_effects(model)
    if not any(e.kind == "relation" for e in section.effects):
        return problem, None
    layout = Layout.from_model(model)
    C = relation_composite(section, layout)
    changed = np.argwhere(C != layout.composite)
    if changed.size == 0:
        return problem, None
    what = ", ".join(f"{layout.dimension_ids[q]} ~ {layout.register_ids[i]} {layout.composite[i, q]:g} → {C[i, q]:.4g}"
                     for i, q in changed)
    note = Note(f"the model's [effects] relation(s) map the correction: {what}",
                SourceLocation(model.source, key="effects"), "relation")
    return dataclasses.replace(problem, composite=C[:, part.measured]), note
