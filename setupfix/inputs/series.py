"""Reading a series for the diagnosis: reports (files, folders or a history store), the
corrections log, the temperature log and the process log → the engine's
:class:`~setupfix.diagnose.Series`.

Folders are listed by the one policy of every command (:func:`parsers.expand_inputs`);
the logs are read by their one reader each (:mod:`parsers.corrections`, checked against
the model by :func:`parsers.corrections.check_corrections`, and
:mod:`parsers.temperature`), from a file or, through the same row checks, a history store.
Each report is read in any supported format and tied to the model; the parts are assembled
into cycles by :mod:`setupfix.inputs.series_assembly`, the logs turned into arrays by
:mod:`setupfix.inputs.series_logs`.  Used by :mod:`setupfix.usecases.diagnosis`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

import parsers
from parsers.corrections import RegisterLog, check_corrections, read_corrections_log
from parsers.folders import LOG_NAMES
from parsers.temperature import TemperatureLog, read_temperature_log
from setupfix.core.errors import MatchError, Note, ParseError, SourceLocation, UnknownFormatError
from setupfix.diagnose import Layout, Series
from setupfix.diagnose.forecast import spec_of
from setupfix.diagnose.terms import PRODUCT, EffectSpec, channel_values
from setupfix.inputs.checks import check_parts
from setupfix.inputs.cycles import ReadOptions
from setupfix.inputs.series_assembly import assemble, one_per_part, ordered_parts, report_coordinates
from setupfix.inputs.series_logs import TempLog, store_temperatures, temperature_arrays
from setupfix.inputs.stores import StoreRef
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts
from setupfix.model.effects import EffectsSection
from setupfix.model.measurements import did_you_mean, match_reports

__all__ = ["SeriesInput", "load_series", "channel_span"]


@dataclass(frozen=True)
class SeriesInput:
    """A series read from files, in the engine's terms."""

    model: ProcessModel
    layout: Layout
    series: Series
    parts: tuple[PartMeasurement, ...]
    declared: tuple[EffectSpec, ...]
    effects: EffectsSection
    corrections: str | None
    temperatures: str | None
    notes: tuple[Note, ...] = ()
    process: str | None = None
    #: reports of the store marked rejected, failed or draft and left out (``include_excluded`` takes them in)
    excluded: int = 0


def _corrections(path: str, model: ProcessModel) -> RegisterLog:
    """A corrections-log file read and checked against the model (the one reader, the one check)."""
    return check_corrections(read_corrections_log(path), model)


def load_series(
    model: ProcessModel | str | Path,
    reports: Sequence[str | Path] = (),
    *,
    corrections: str | None = None,
    temperatures: str | None = None,
    db: str | Path | StoreRef | None = None,
    thermal: str | Path | None = None,
    read: ReadOptions | None = None,
    process: str | None = None,
    include_excluded: bool = False,
) -> SeriesInput:
    """Read a series of reports (files, folders, or every report of a history store) with its logs.

    With ``db`` the store's reports, corrections log and temperatures are used (files
    given as well are added; a corrections or temperature file given replaces the
    store's log).  With ``thermal`` (a model saved by ``setupfix thermal fit``) its
    predicted drift over the temperature log becomes one more channel, so the thermal
    candidate tests the thermal slice's model itself (its measured-error column is
    not used as a channel).  ``read``: the report reader's options (``lenient`` lets a
    reader skip a self-contradicting row, a note names its line).  ``process``: a process
    log (CSV or ``.xlsx``), its channels joined per cycle (:func:`process_channels`).
    The reports a store keeps marked (rejected, failed, draft) are left out, and counted in a
    note and :attr:`SeriesInput.excluded`, unless ``include_excluded``.  A part reported
    twice (any format, a copy) is one cycle (:func:`setupfix.inputs.series_assembly.one_per_part`).

    Raises
    ------
    SetupfixError
        Any unreadable or unmatchable file, naming it and the place.
    """
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    section = model.effects
    read_options = read if read is not None else ReadOptions()
    notes: list[Note] = []
    parts: list[PartMeasurement] = []
    tables: list[pd.DataFrame] = []
    log = temps = None
    excluded = 0
    where = StoreRef.of(db).location if db is not None else ""
    if db is not None:
        from setupfix.inputs.smoothing import excluded_note
        from setupfix.store import excluded_reports, report_rows, stored_corrections

        with StoreRef.of(db).for_model(model).open() as store:
            if not include_excluded:
                excluded = len(excluded_reports(store))
                if excluded:
                    notes.append(excluded_note(excluded, "the series"))
            records, rows, starts = report_rows(store, include_excluded=include_excluded)
            if records:  # every report matched in one pass (a machine-year is 8,760 reports)
                measured = ~rows["reference"].to_numpy(dtype=bool)
                table = rows[measured]
                kept_before = np.r_[0, np.cumsum(measured)]
                sources = [f"{where}#{rec.name}" for rec in records]
                for found in match_reports(model, table, kept_before[starts], sources):
                    parts += found
                tables.append(table)
            if corrections is None:
                log = stored_corrections(store, model)
            if temperatures is None:
                stored_t = store.temperatures()
                if len(stored_t.columns) > 1 and not stored_t.empty:
                    temps = store_temperatures(stored_t, f"{where}#temperatures")
    if reports:
        inputs = parsers.expand_inputs(reports)
        notes += inputs.notes()
        if not inputs.files:
            raise ParseError(
                "no report found",
                location=SourceLocation(", ".join(str(p) for p in reports)),
                hint="; ".join(inputs.warnings()[:3]) or None,
            )
        where = where or inputs.files[0][0]
        found_log, found_temp = inputs.log("corrections"), inputs.log("temperatures")
        if corrections is None and found_log and log is None:
            corrections = found_log
            notes.append(Note(f"corrections log {found_log} found beside the reports: used", None, "series"))
        if temperatures is None and found_temp and temps is None:
            temperatures = found_temp
            notes.append(Note(f"temperature log {found_temp} found beside the reports: used", None, "series"))
        for f, from_folder in inputs.files:
            try:
                result = parsers.read_report(f, **read_options.kwargs())
            except UnknownFormatError as exc:
                if not from_folder:
                    raise
                notes.append(Note("not a report of a known format; left out", exc.location, "format"))
                continue
            table = result.table
            notes += result.notes
            parts += check_parts(model, match_parts(model, table, source=f), source=f)
            tables.append(table)
    if not parts:
        raise ParseError(
            "no report in the series",
            location=SourceLocation(where or "<series>"),
            hint=f"{excluded} stored report(s) marked rejected, failed or draft were left out: "
            "--include-excluded takes them in"
            if excluded
            else None,
        )
    parts, more = one_per_part(parts)
    notes += more
    if not corrections and log is None and len(parts) > 1:
        notes.append(Note(_no_log_note(reports), None, "series"))
    if corrections:
        log = _corrections(corrections, model)
    temp_log = None
    if temperatures:
        temp_log = read_temperature_log(temperatures)
        notes += temp_log.notes
        temps = temperature_arrays(temp_log)
    if thermal is not None:
        if temp_log is None or temps is None:
            raise ParseError(
                "a thermal model needs the temperature log it predicts from",
                location=SourceLocation(str(thermal)),
                hint="give --temperatures",
            )
        temps, more_notes = _with_thermal_prediction(temps, str(thermal), temp_log)
        notes += more_notes
    process_log = None
    if process:
        process_log = read_temperature_log(process, require_time=False, keep_text=True)
        notes += process_log.notes
    series, more = assemble(model, parts, log, temps, where, process_log)
    notes += more
    declared = tuple(spec_of(e) for e in section.effects)
    for e in section.effects:
        if e.kind == "thermal" and e.channel not in series.channels:
            raise MatchError(
                f"the model's thermal effect {e.id} needs temperature channel {e.channel!r}",
                location=SourceLocation(model.source, key=f"effects.{e.id}.channel"),
                hint="give --temperatures",
            )
        if e.kind == "process" and not _has_channel(series, str(e.channel)):
            raise MatchError(
                f"the model's process effect {e.id} needs process channel {e.channel!r}",
                location=SourceLocation(model.source, key=f"effects.{e.id}.channel"),
                hint="give --process with the log it was found in",
            )
    unmatched = sorted({u for p in parts for u in p.unmatched})
    if unmatched:
        meant = {u: m for p in parts for u, m in did_you_mean(model, p).items()}  # correct's suggestions
        named = [f"{u} (did you mean {meant[u]!r}?)" if u in meant else u for u in unmatched]
        notes.append(
            Note(
                f"{len(unmatched)} characteristic(s) match no dimension: {', '.join(named[:6])}"
                + (" …" if len(unmatched) > 6 else ""),
                None,
                "match",
            )
        )
    layout = Layout.from_model(model, coord=report_coordinates(model, tables))
    if np.isfinite(layout.coord).all() and not all(f.position for f in model.features):
        notes.append(
            Note("dimension coordinates for position effects taken from the reports' x, y, z columns", None, "series")
        )
    return SeriesInput(
        model,
        layout,
        series,
        tuple(ordered_parts(parts)),
        declared,
        section,
        corrections,
        temperatures,
        tuple(notes),
        process,
        excluded,
    )


def _has_channel(series: Series, name: str) -> bool:
    """A process channel of the series, or a product of them (a declared interaction)."""
    known = set(series.process_channels)
    return name in known or (PRODUCT in name and all(p in known for p in name.split(PRODUCT)))


def _no_log_note(reports: Sequence[str | Path]) -> str:
    """The note for a series read without a corrections log (naming a log file lying beside a report)."""
    beside = sorted(
        {
            str(Path(r).parent / n)
            for r in reports
            if not Path(r).is_dir()
            for n, kind in LOG_NAMES.items()
            if kind == "corrections" and (Path(r).parent / n).is_file()
        }
    )
    text = (
        "no corrections log: every part is taken as cut with the same offsets, so a correction applied "
        "during the series would show as drift or a step"
    )
    return text + (f"; {beside[0]} lies beside the reports: give it with --corrections" if beside else "")


def _with_thermal_prediction(temps: TempLog, thermal: str, log: TemperatureLog) -> tuple[TempLog, list[Note]]:
    """The temperature channels plus the drift a saved thermal model predicts over the same log."""
    from setupfix.inputs.thermal_files import predict_drift

    pred = predict_drift(thermal, log)
    times, samples, channels = temps
    keep = [j for j, c in enumerate(channels) if c != pred.target]
    name = f"{pred.method} prediction"
    notes = list(pred.notes)
    notes.append(
        Note(
            f"thermal model {thermal} ({pred.method}, {pred.unit or 'unit not stated'}): its prediction "
            f"is the channel {name!r}",
            None,
            "thermal",
        )
    )
    return (times, np.column_stack([samples[:, keep], pred.drift]), (*(channels[j] for j in keep), name)), notes


def channel_span(series: Series, spec: EffectSpec) -> float:
    """Range of a spec's channel over the series (the span a process effect was found over)."""
    return float(np.ptp(channel_values(series, str(spec.channel)))) if series.n_cycles else 0.0
