"""Use case "diagnose": a series of reports, the corrections log and temperatures → diagnosis.

Shared by ``setupfix diagnose``, the TUI and the benches.  Steps: load the model (and
its ``[effects]``) → the series (:mod:`setupfix.inputs.series`: every report, one
cycle per machined part, with the corrections in effect, the parts cut since each tool
change and the temperatures) → the engine
(:class:`setupfix.diagnose.Diagnoser`) → the next correction (:func:`recommend_next`:
``correct_cycle`` on the forecast of the model that earned it in the walk forward —
augmented, or EWMA over the series' :class:`History`, or declared — with the registers
the centre rule holds fixed) → JSON per ``../shared/spec/cli-json.md`` and, with ``augment``, the model
with the effects found written as its ``[effects]`` section.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from setupfix.core.errors import ExportError, MatchError, ModelError, Note, ParameterError, SourceLocation
from setupfix.correction.safety import RuleEffect, short_list
from setupfix.diagnose import Diagnoser, Diagnosis
from setupfix.diagnose.covariates import typical_step
from setupfix.diagnose.factors import Term, factor_channels, parse_terms
from setupfix.diagnose.terms import PRODUCT
from setupfix.inputs.series import SeriesInput, channel_span, load_series
from setupfix.inputs.stores import StoreRef
from setupfix.model import PartMeasurement, ProcessModel, model_from_dict
from setupfix.model.effects import EffectsSection, ModelEffect, effects_from_dict
from setupfix.model.effects_toml import with_effects
from setupfix.outputs.writers import check_target, write_text
from setupfix.usecases.correct import correct_cycle
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, History, ReadOptions, SolveOptions

__all__ = [
    "DiagnoseRequest",
    "DiagnoseOutcome",
    "note_text",
    "diagnose_reports",
    "augmented_section",
    "declared_terms",
    "write_augmented",
    "forecast_model",
    "recommend_next",
    "series_history",
]


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
            target = (
                f"{sp.dimension} ~ one of {', '.join(res.registers)} "
                f"(the series cannot tell which; {sp.register} fitted)"
            )
        effects.append(
            ModelEffect(
                id=f"E{n}",
                kind=sp.kind,
                estimate=float(f"{res.estimate:.6g}"),
                stderr=float(f"{res.stderr:.3g}"),
                unit=res.unit,
                target=target,
                shape=sp.shape,
                tau=sp.tau if sp.shape == "saturating" else None,
                channel=sp.channel,
                reference=sp.reference,
                register=sp.register,
                dimension=sp.dimension,
                axis=sp.axis,
                along=sp.along,
                group=sp.group,
                registers=res.registers if len(res.registers) > 1 else (),
                at=sp.at if sp.kind == "level" else None,
                cycle=sp.cycle if sp.kind == "level" else None,
                span=channel_span(s, sp) if sp.kind == "process" else None,
            )
        )
        used.add(f"E{n}")
    return EffectsSection(
        tuple(effects),
        s.origin or declared.origin,
        step if step else declared.cycle_hours,
        float(s.time[-1]) if s.n_cycles else declared.last_hours,
    )


@dataclass(frozen=True)
class DiagnoseRequest:
    """Everything ``diagnose`` needs: the model, the series' sources and the engine's settings.

    ``reports`` are files or folders (or none with ``db``); ``read`` the reader's options
    (``lenient`` lets a reader skip a self-contradicting row); ``corrections`` and
    ``temperatures`` the logs (found beside the reports when not given); ``db`` a history
    store; ``thermal`` a model saved by ``setupfix thermal fit``; ``augment`` where to write
    the model with the effects found; ``diagnoser`` the engine with its settings.
    """

    model: ProcessModel | str | Path
    reports: tuple[str | Path, ...] = ()
    read: ReadOptions = field(default_factory=ReadOptions)
    corrections: str | None = None
    temperatures: str | None = None
    db: str | Path | StoreRef | None = None
    thermal: str | Path | None = None
    augment: str | Path | None = None
    process: str | None = None  #: process log (channels of any name and unit, joined per cycle)
    #: declared design factors, ``a``, ``b``, ``a*b`` (process-log columns; :mod:`setupfix.diagnose.factors`)
    factors: tuple[str, ...] = ()
    diagnoser: Diagnoser = field(default_factory=Diagnoser)
    solve: SolveOptions = field(default_factory=SolveOptions)  #: the next correction's optimiser (objective)
    #: take in the reports the store keeps marked rejected, failed or draft (left out and counted by default)
    include_excluded: bool = False


def note_text(note: Note) -> str:
    """A note of the diagnosis as a line of its JSON (a folder's problem is a warning)."""
    return f"warning: {note}" if note.kind == "folder" else str(note)


@dataclass(frozen=True, eq=False)
class DiagnoseOutcome:
    """A diagnosis with what the CLI and TUI show: next correction, notes, augmented file."""

    input: SeriesInput
    diagnosis: Diagnosis
    next_correction: Mapping[str, float]
    augmented: str | None = None
    notes: tuple[Note, ...] = ()
    #: ``correct`` on the forecast (None when nothing was measured); ``next_correction`` is its corrections
    #: (none for a draft model: :attr:`draft`).
    next_cycle: CycleCorrection | None = None

    @property
    def draft(self) -> bool:
        """Whether the model is a draft (``[process] draft = true``): no next correction is given."""
        return self.input.model.draft

    def to_json(self) -> dict[str, Any]:
        """The ``diagnose --json`` object of ``../shared/spec/cli-json.md`` (plus extra keys)."""
        d = self.diagnosis
        lay = d.layout
        names = {dim.id: dim.name for dim in self.input.model.dimensions}

        def r(v: float, digits: int = 9) -> float | None:
            return round(float(v), digits) if math.isfinite(v) else None

        out: dict[str, Any] = {
            "cycles": d.series.n_cycles,
            "rms_before": r(d.error_before.rms),
            "rms_after": r(d.error_after.rms),
            "max_before": r(d.error_before.max),
            "max_after": r(d.error_after.max),
            "out_of_tolerance_before": d.error_before.out_of_tolerance,
            "out_of_tolerance_after": d.error_after.out_of_tolerance,
            "effects": [
                {
                    "kind": e.kind,
                    "target": e.target,
                    "estimate": r(e.estimate, 12),
                    "stderr": r(e.stderr, 12),
                    "unit": e.unit,
                    "rms_after": r(e.rms_after),
                    "alike": list(e.alike),
                    **({"registers": list(e.registers)} if e.kind == "relation" else {}),
                    **({"cycle": e.spec.cycle, "at_hours": e.spec.at} if e.kind == "level" else {}),
                    **({"channel": e.spec.channel, "register": e.spec.register} if e.kind == "process" else {}),
                    "source": e.source,
                    "p": r(e.p, 12) if e.p is not None else None,
                }
                for e in d.effects
            ],
            "declared_factors": []
            if d.factors is None
            else [
                {
                    "term": t.term.name,
                    "register": t.register,
                    "channels": [str(s.channel) for s in t.specs],
                    "f": r(t.f, 6),
                    "p": r(t.p, 12),
                    "p_holm": r(t.p_holm, 12),
                    "df": t.q,
                    "accepted": t.accepted,
                }
                for t in d.factors.tests
            ],
            # a draft's next correction is no number, not even zero: null, and "draft" says why
            "next_correction": None if self.draft else {k: round(v, 9) for k, v in self.next_correction.items()},
            "next_solved": self.next_cycle.solved if self.next_cycle is not None else None,
            "draft": self.draft,
            "excluded_reports": self.input.excluded,
            "declared_effects": [e.target for e in self.input.declared],
            "rejected": [
                {
                    "kind": s.spec.kind,
                    "target": s.target,
                    "p_adjusted": r(s.p_adjusted, 6),
                    "cv_before": r(s.cv_before),
                    "cv_after": r(s.cv_after),
                }
                for s in d.selection.steps
                if not s.accepted
            ],
            "unidentifiable": list(d.selection.unidentifiable),
            "lack_of_fit": d.selection.lack_of_fit,
            "dimensions": [
                {
                    "id": did,
                    "name": names[did],
                    "rms_before": r(d.error_before.rms_by_dimension[q]),
                    "rms_after": r(d.error_after.rms_by_dimension[q]),
                    "max_before": r(d.error_before.max_by_dimension[q]),
                    "max_after": r(d.error_after.max_by_dimension[q]),
                    "forecast": r(d.forecast[q]),
                }
                for q, did in enumerate(lay.dimension_ids)
            ],
            "per_cycle": [
                {
                    "cycle": c,
                    "rms_before": r(d.error_before.rms_by_cycle[k]),
                    "rms_after": r(d.error_after.rms_by_cycle[k]),
                    "max_before": r(d.error_before.max_by_cycle[k]),
                    "max_after": r(d.error_after.max_by_cycle[k]),
                }
                for k, c in enumerate(d.series.cycles)
            ],
            "walk_forward": None
            if d.walk is None
            else {
                "cycles_scored": len(d.walk.cycles),
                "cycles_walked": len(d.walk.walked or d.walk.cycles),
                "scored_from": (d.walk.cycles[0] + 1) if d.walk.cycles else None,
                "score_start": "stated" if d.walk.stated else ("stable" if d.walk.late else "first"),
                "whole_walk": None
                if d.walk.whole is None
                else {
                    name: {"centre_rms": r(b.centre_rms), "out_of_tolerance": b.out_of_tolerance}
                    for name, b in d.walk.whole.items()
                },
                **{
                    name: {
                        "mean_budget": r(b.mean_budget),
                        "worst_budget": r(b.worst_budget),
                        "rms": r(b.rms),
                        "out_of_tolerance": b.out_of_tolerance,
                        "centre_rms": r(b.centre_rms),
                        "centre_mean_abs": r(b.centre_mean_abs),
                    }
                    for name, b in d.walk.budgets.items()
                },
            },
            "next_from": d.next_from.source,
            "next_from_reason": d.next_from.reason,
            "held_centred": [rid for rid, h in zip(lay.register_ids, d.centred, strict=True) if h]
            if d.centred is not None
            else [],
            "augmented": self.augmented,
            "notes": [note_text(n) for n in self.notes],
        }
        return out


def forecast_model(model: ProcessModel) -> ProcessModel:
    """The model ``correct`` poses the diagnosis's forecast with.

    The forecast is already the next cycle, smoothed over the series, with every effect
    found or declared: the model's own ``[effects]`` forecast and the EWMA must not act
    on it a second time (its relations come in through the augmented matrix).
    """
    return dataclasses.replace(model, effects=EffectsSection(), safety=dataclasses.replace(model.safety, ewma=1.0))


def _hold(model: ProcessModel, diagnosis: Diagnosis, fraction: float) -> RuleEffect | None:
    """The centre rule as the posed problem's fixed registers (None when it holds nothing)."""
    if diagnosis.centred is None or not diagnosis.centred.any():
        return None
    regs = tuple(r for r, h in zip(model.registers, diagnosis.centred, strict=True) if h)
    C = diagnosis.next_matrix()
    dims = tuple(diagnosis.layout.dimension_ids[q] for q in np.flatnonzero(np.any(C[diagnosis.centred] != 0, axis=0)))
    return RuleEffect(
        "centred",
        f"{short_list(r.register for r in regs)} held: every dimension they move sat within "
        f"{fraction:g} of its half tolerance from the centre on the last two parts and is forecast to "
        "stay there (never move what sits at the centre)",
        registers=tuple(r.id for r in regs),
        dimensions=dims,
    )


def series_history(model: ProcessModel, diagnosis: Diagnosis) -> tuple[History, PartMeasurement]:
    """The series as the smoothing's history, and its last part at the registers the next cycle has.

    Parts get the series' times (cycle index as hours when it has none); the register
    states between parts become the corrections log, with the logged changes after the
    last part dated just before it (so every part is moved to the registers now).
    """
    s = diagnosis.series
    n_reg = len(model.registers)
    origin = np.datetime64(s.origin or "2000-01-01T00:00:00", "ns")
    times = origin + np.round(s.time * 3.6e12).astype("timedelta64[ns]")
    pending = s.pending if s.pending.size == n_reg else np.zeros(n_reg)
    steps = np.diff(np.vstack([s.applied, s.applied[-1] + pending]), axis=0)  # (n, n_reg): after part k
    when = (np.concatenate([times[1:], times[-1:]]) - np.timedelta64(1, "ns")).astype("datetime64[ns]")
    k, i = np.nonzero(steps)
    history = History(
        times[:-1],
        s.deviation[:-1].copy(),
        tuple(s.cycles[:-1]) if s.cycles else (),
        when[k],
        i.astype(np.int64),
        steps[k, i].astype(float),
        np.zeros(k.size, dtype=bool),
    )
    cycle = s.cycles[-1] if s.cycles else "last"
    dev = s.deviation[-1] + pending @ diagnosis.layout.composite
    stamp = str(times[-1].astype("datetime64[s]"))
    return history, PartMeasurement(
        part=cycle, report="series", timestamp=stamp, deviation=dev, sources=tuple("" for _ in dev)
    )


def recommend_next(
    model: ProcessModel, diagnosis: Diagnosis, solve: SolveOptions | None = None, diagnoser: Diagnoser | None = None
) -> tuple[CycleCorrection | None, list[Note]]:
    """``correct`` for the next cycle, from the model that earned it (``diagnosis.next_from``).

    Augmented or declared: the model's forecast posed through its relation matrix; EWMA: the
    last part smoothed over the series (the one use case, :func:`correct_cycle` with a
    :class:`History`, λ the diagnoser's).  The centre rule holds its registers (``hold``).
    """
    source = diagnosis.next_from.source
    fc = diagnosis.forecast if diagnosis.next_forecast is None else diagnosis.next_forecast
    if not np.isfinite(fc).any():
        return None, [Note("no forecast: nothing measured", None, "diagnosis")]
    diagnoser = diagnoser or Diagnoser()
    hold = _hold(model, diagnosis, diagnoser.centre_fraction)
    request = CorrectRequest(forecast_model(model), solve=solve or SolveOptions())
    if source == "ewma":
        history, part = series_history(model, diagnosis)
        lam = float(diagnoser.lam or 1.0)
        ewma_model = dataclasses.replace(request.model, safety=dataclasses.replace(request.model.safety, ewma=lam))
        request = dataclasses.replace(request, model=ewma_model, history=history)
        composite = diagnosis.layout.composite
    else:
        part = PartMeasurement(
            part="next", report="forecast", timestamp=None, deviation=fc, sources=tuple("" for _ in fc)
        )
        composite = diagnosis.next_matrix()
    cycle = correct_cycle(request, part, composite=composite, hold=hold)
    notes = list(cycle.notes)
    if diagnosis.next_from.reason and source != "augmented" and diagnosis.effects:
        notes.append(Note(f"next correction: {diagnosis.next_from.reason}", None, "diagnosis"))
    if hold is not None:
        notes.append(Note(f"next correction: {hold.message}", None, "diagnosis"))
    if model.draft:  # the draft's hold is no correction (as ``correct`` states it: its alarm)
        notes.append(Note(f"no next correction: {cycle.recommendation.alarm}", None, "draft"))
    elif cycle.verdict == "reject":
        notes.append(Note(f"next correction: {cycle.recommendation.alarm}", None, "safety"))
    elif not cycle.solved:
        why = next(r.message for r in cycle.recommendation.rules if r.rule == "not_solved")
        notes.append(Note(f"next correction: {why}", None, "solver"))
    return cycle, notes


def diagnose_reports(request: DiagnoseRequest) -> DiagnoseOutcome:
    """Diagnose a series of reports; optionally write the augmented model.

    Raises
    ------
    SetupfixError
        Bad input (named with its place) or an augmented file that cannot be written;
        nothing is half-written.
    """
    if request.augment:
        check_target(request.augment)  # a bad target costs nothing
    inp = load_series(
        request.model,
        request.reports,
        corrections=request.corrections,
        temperatures=request.temperatures,
        db=request.db,
        thermal=request.thermal,
        read=request.read,
        process=request.process,
        include_excluded=request.include_excluded,
    )
    diagnosis = request.diagnoser.run(
        inp.layout, inp.series, declared=inp.declared, factors=declared_terms(request.factors, inp)
    )
    cycle, more = recommend_next(inp.model, diagnosis, request.solve, request.diagnoser)
    notes = (*inp.notes, *(Note(n, None, "diagnosis") for n in diagnosis.notes), *more)
    moves = cycle.corrections if cycle is not None and not inp.model.draft else {}
    out = DiagnoseOutcome(inp, diagnosis, moves, None, notes, cycle)
    if request.db is not None:
        _record(request.db, inp.model, out)
    if request.augment:
        written = write_augmented(inp.model, augmented_section(diagnosis, inp.effects), str(request.augment))
        out = dataclasses.replace(out, augmented=written)
    return out


def declared_terms(factors: tuple[str, ...], inp: SeriesInput) -> tuple[Term, ...]:
    """The declared design factors as terms, each factor a channel of the series' process log.

    Raises
    ------
    ParameterError
        If a term is malformed or factors are declared without a process log.
    MatchError
        If a factor is no column of the process log (the message names it and the log).
    """
    if not factors:
        return ()
    try:
        terms = parse_terms(factors)
    except ValueError as exc:
        raise ParameterError(f"--factors: {exc}") from None
    if not inp.process:
        raise ParameterError("--factors names process-log columns: give the log with --process")
    for f in dict.fromkeys(f for t in terms for f in t.factors):
        try:
            factor_channels(inp.series, f)
        except KeyError:
            known = sorted({c.split("=", 1)[0] for c in inp.series.process_channels if PRODUCT not in c})
            raise MatchError(
                f"--factors: the process log has no usable column {f!r} (columns: {', '.join(known)})",
                location=SourceLocation(inp.process),
            ) from None
    return terms


def _record(db: str | Path | StoreRef, model: ProcessModel, out: DiagnoseOutcome) -> None:
    """Keep the recommended next correction in the history store, with what it was computed from."""
    import hashlib

    from setupfix.store import Recommendation

    doc = out.to_json()
    result = {
        k: doc[k]
        for k in ("cycles", "rms_before", "rms_after", "max_before", "max_after", "effects", "next_correction", "draft")
    }
    inputs: dict[str, Any] = {
        "command": "diagnose",
        "model": model.source,
        "corrections": out.input.corrections,
        "temperatures": out.input.temperatures,
    }
    if Path(model.source).is_file():
        inputs["model_sha256"] = hashlib.sha256(Path(model.source).read_bytes()).hexdigest()
    with StoreRef.of(db).for_model(model).open() as store, store.transaction():
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
        raise ExportError(
            f"cannot read the model to augment: {exc.strerror}", location=SourceLocation(model.source)
        ) from None
    new = with_effects(text, section)
    try:  # what is written must load, model and effects
        doc = tomllib.loads(new)
        check = model_from_dict(doc, source=target)
        effects_from_dict(doc.get("effects"), check, target)
    except (tomllib.TOMLDecodeError, ModelError) as exc:
        raise ExportError(f"the augmented model would not load: {exc}", location=SourceLocation(target)) from None
    write_text(target, new)
    return target
