"""Use case "correct": from a typed request and a CMM report to one recommendation per cycle.

The only path to a recommendation, for every door (CLI, batch, TUI, diagnose).  Steps:
read the report once (any supported format) → tie characteristics to dimensions
(part by part, stations merged into fixture cycles) → per cycle
(:func:`correct_cycle`): the smoothing over the history, the problem posed by
:func:`setupfix.correction.pose.pose_problem` (forecast, relations, guard band, cumulative
bounds, costs, fixed registers), the optimiser, the rules after the solve
(:func:`setupfix.correction.recommend.recommend`), the thermal feed-forward with its limit check →
an immutable :class:`~setupfix.usecases.requests.CycleCorrection`.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import parsers
from setupfix.core.errors import Note, ParameterError, SetupfixError
from setupfix.correction.ewma import Smoothed
from setupfix.correction.pose import PosedProblem, pose_problem
from setupfix.correction.recommend import recommend
from setupfix.correction.safety import Recommendation, RuleEffect, short_list
from setupfix.inputs.cycles import read_parts
from setupfix.inputs.rules_history import mean_smoothed, with_history_rules, with_report_uncertainty
from setupfix.inputs.stores import StoreRef
from setupfix.model import PartMeasurement, ProcessModel, load_model
from setupfix.model.measurements import did_you_mean
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.store import Store
from setupfix.usecases.requests import (
    CorrectOutcome,
    CorrectRequest,
    CurrentOffsets,
    CycleCorrection,
    CycleOptions,
    History,
    ReadOptions,
    SolveOptions,
    ThermalInputs,
    load_thermal,
)

if TYPE_CHECKING:
    from setupfix.usecases.thermal_feedforward import ThermalFeedForward

__all__ = ["correct_report", "correct_cycle", "pose_cycle", "read_cycles", "load_request", "open_history"]


def _applied_result(problem: CorrectionProblem, rec: Recommendation) -> OptimizeResult:
    """The optimiser's result restated for the changes actually recommended.

    ``x``, δ after, norm and binding dimensions are those of ``rec.x`` on the real
    tolerance limits (the raw optimum stays in ``rec.result``), so every reader of
    ``CycleCorrection.result`` — tables, JSON, the TUI — shows what is to be applied.
    """
    raw = rec.result
    x = np.asarray(rec.x, dtype=float)
    if rec.verdict == "reject" or not rec.solved:  # nothing was solved: nothing binds
        binding: tuple[str, ...] = ()
    elif rec.verdict == "apply" and np.array_equal(x, raw.x) and raw.binding:
        binding = raw.binding
    else:
        binding = problem.binding(x)
    message = raw.message
    if rec.verdict == "hold":
        message = "hold: " + next(
            (r.message for r in rec.rules if r.rule in ("not_solved", "dead_band", "no_harm", "draft")),
            "no change needed",
        )
    return dataclasses.replace(
        raw,
        x=x.copy(),
        margin_before=problem.dimension_budget(0 * x, rec.given_up)[0],
        margin_after=problem.dimension_budget(x, rec.given_up)[0],
        norm=float(np.linalg.norm(x)),
        binding=problem.dimension_of(binding),
        message=message,
    )


def _smoothed(request: CorrectRequest, part: PartMeasurement) -> Smoothed | None:
    lam = request.model.safety.ewma
    if lam >= 1.0:
        return mean_smoothed(request.model, request.history, part)  # [safety] mean_of (None when 1)
    if request.history is None:
        note = Note(f"ewma = {lam:g} needs the history store (--store): deviations not smoothed", None, "ewma")
        return Smoothed(part.deviation, 0, lam, (note,))
    return request.history.smooth(request.model, part, lam)


def _feed_forward(thermal: ThermalInputs, cycle: CycleCorrection) -> ThermalFeedForward:
    """The thermal feed-forward of one cycle, refused when setup plus feed-forward exceed a register's limit.

    Raises
    ------
    ParameterError
        The sum exceeds a register's limit (or the thermal inputs do not fit the cycle).
    """
    from setupfix.usecases.thermal_feedforward import thermal_feed_forward  # scipy.signal: only with thermal inputs

    model = cycle.model
    ff = thermal_feed_forward(
        model, thermal.saved, thermal.log, measured_at=cycle.part.timestamp, at=thermal.at, dead_band=thermal.dead_band
    )
    setup = cycle.corrections  # the setup correction alone (verdict applied)
    for reg in model.registers:
        total = setup.get(reg.id, 0.0) + ff.corrections().get(reg.id, 0.0)
        if abs(total) > reg.limit + 1e-12:
            raise ParameterError(
                f"setup correction plus thermal feed-forward on {reg.register} "
                f"({total:+g} {model.unit}) exceeds its limit ±{reg.limit:g}",
                hint=f"{thermal.source}: check the thermal model or the temperature log",
            )
    return ff


def pose_cycle(
    request: CorrectRequest,
    part: PartMeasurement,
    *,
    composite: np.ndarray | None = None,
    hold: RuleEffect | None = None,
) -> PosedProblem:
    """The problem of one measured cycle as ``correct`` poses it: the one problem builder of every door.

    The smoothing over ``request.history``, its stand-ins for dimensions the report lacks, the
    cumulative bounds of ``request.current``'s wear totals, then
    :func:`setupfix.correction.pose.pose_problem` (``composite`` and ``hold`` as in
    :func:`correct_cycle`).  ``compare`` solves exactly this problem.
    """
    model = request.model
    cumulative = request.current.wear_totals(model) if request.current is not None else None
    stand_in = request.history.stand_in(model, part) if request.history is not None else None
    smoothed = _smoothed(request, part)
    posed = pose_problem(
        with_report_uncertainty(model, part),  # the report's own U wins (guard band)
        part,
        smoothed=smoothed,
        cumulative=cumulative,
        composite=composite,
        stand_in=stand_in,
        hold=hold,
    )
    averaged = smoothed if model.safety.mean_of > 1 and model.safety.ewma >= 1.0 else None
    return with_history_rules(posed, model, request.history, part, averaged)  # dead band %, min_parts


def read_cycles(
    request: CorrectRequest, report: str | Path | parsers.Source
) -> tuple[parsers.Source, parsers.ReadResult, list[PartMeasurement]]:
    """Read a report once and tie it to the model: the source, what was read, the cycles ``request`` selects.

    Raises
    ------
    SetupfixError
        Unreadable or unmatchable report, unknown part (named with file and place).
    """
    source = parsers.load_source(report)
    read, parts = read_parts(request.model, source, **request.read.kwargs(), **request.cycles.kwargs())
    return source, read, request.cycles.select(parts, source.name)


def correct_cycle(
    request: CorrectRequest,
    part: PartMeasurement,
    *,
    composite: np.ndarray | None = None,
    hold: RuleEffect | None = None,
) -> CycleCorrection:
    """Recommend the corrections of one measured cycle: optimum under the model's safety rules.

    ``composite`` replaces the model's relation matrix (the diagnosis's augmented one,
    shape (n_registers, n_dimensions)); ``hold`` holds its registers at 0 (the
    diagnosis's centre rule, :func:`setupfix.correction.pose.pose_problem`).
    """
    model = request.model
    posed = pose_cycle(request, part, composite=composite, hold=hold)
    solve = request.solve
    opt = get_optimizer(solve.optimizer, seed=solve.seed, **solve.params())
    names = {d.id: d.name for d in model.dimensions}
    if posed.problem.rows is not None:  # a zone's facets are named by the zone
        names |= {c: names[r] for c, r in zip(posed.problem.dimension_ids, posed.problem.rows, strict=True)}
    rec = recommend(
        posed,
        opt.solve,
        optimizer=solve.optimizer,
        names=names,
        registers={r.id: r.register for r in model.registers},
        unit=model.unit,
        draft=model.source if model.draft else None,
    )
    notes = [*part.notes, *posed.notes, *(n for n in rec.result.notes if n.message != rec.result.message)]
    if part.absent:
        notes.append(
            Note(
                f"{len(part.absent)} dimension(s) absent from the report, left out: {short_list(part.absent)}",
                None,
                "match",
            )
        )
    if part.unmatched:
        meant = did_you_mean(model, part)  # the one suggestion rule, as model check offers it
        notes.append(
            Note(
                f"{len(part.unmatched)} characteristic(s) match no dimension: "
                + short_list(f"{u} (did you mean {meant[u]!r}?)" if u in meant else u for u in part.unmatched),
                None,
                "match",
            )
        )
    cycle = CycleCorrection(model, part, posed, _applied_result(posed.problem, rec), rec, None, tuple(notes))
    if request.thermal is not None:
        cycle = dataclasses.replace(cycle, thermal=_feed_forward(request.thermal, cycle))
    return cycle


def correct_report(request: CorrectRequest, report: str | Path | parsers.Source) -> CorrectOutcome:
    """Correct every cycle of a report (or the one ``request.cycles.part`` names).

    The report is read once (``report`` may be a :class:`parsers.Source` already
    loaded, e.g. by batch).

    Returns
    -------
    CorrectOutcome

    Raises
    ------
    SetupfixError
        Unreadable or unmatchable report, unknown part, bad thermal inputs (named with
        file and place).
    """
    source, read, parts = read_cycles(request, report)
    cycles = tuple(correct_cycle(request, p) for p in parts)
    return CorrectOutcome(
        report=source.name,
        format=read.format,
        sha256=hashlib.sha256(source.data).hexdigest(),
        table=read.table,
        cycles=cycles,
        notes=tuple(read.notes),
    )


def load_request(
    model: ProcessModel | str | Path,
    *,
    read: ReadOptions | None = None,
    cycles: CycleOptions | None = None,
    solve: SolveOptions | None = None,
    current: str | Path | CurrentOffsets | None = None,
    store: str | Path | StoreRef | None = None,
    thermal: str | Path | None = None,
    temperatures: str | Path | None = None,
    at: str | None = None,
    thermal_dead_band: float | None = None,
    include_excluded: bool = False,
) -> CorrectRequest:
    """A :class:`CorrectRequest` with every input file read once (the CLI's and the TUI's way to build one).

    ``current``: the controller's current offsets (``register,value``); ``store``: the
    history store (the smoothing's earlier parts when ``[safety] ewma`` < 1, and the recent
    measurements that stand in for dimensions a report lacks), its reports marked rejected,
    failed or draft left out unless ``include_excluded`` (the smoothing's notes count them);
    ``thermal`` and ``temperatures`` (together): the feed-forward's inputs.

    Raises
    ------
    SetupfixError
        A file that cannot be read or does not fit the model (named with its place),
        ``thermal`` without ``temperatures`` or the reverse, a store that does not exist.
    """
    if (thermal is None) != (temperatures is None):
        raise SetupfixError("--thermal and --temperatures go together")
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    history_store = open_history(store, model) if store is not None else None
    if isinstance(current, CurrentOffsets):  # read from the control (``--link``): already the model's values
        offsets: CurrentOffsets | None = current
    else:
        offsets = CurrentOffsets.read(current, model) if current is not None else None
    history = None
    if history_store is not None:
        with history_store as opened:  # read once: the smoothing needs the earlier parts and the log
            history = History.from_store(model, opened, include_excluded=include_excluded)
    inputs = (
        load_thermal(thermal, temperatures, at=at, dead_band=thermal_dead_band)
        if thermal is not None and temperatures is not None
        else None
    )
    return CorrectRequest(
        model, read or ReadOptions(), cycles or CycleOptions(), solve or SolveOptions(), offsets, history, inputs
    )


def open_history(store: str | Path | StoreRef, model: ProcessModel) -> Store:
    """Open an existing history store for the model's machine (a missing file is an error, not a new empty store)."""
    return StoreRef.of(store).for_model(model).open()
