"""Reading a series for the diagnosis: reports (files, folders or a history store), the
corrections log, the temperature log and the process log → the engine's
:class:`~setupfix.diagnose.Series`.

Folders are listed by the one policy of every command (:func:`parsers.expand_inputs`);
the logs are read by their one reader each (:mod:`parsers.corrections`, checked against
the model by :func:`parsers.corrections.check_corrections`, and
:mod:`parsers.temperature`), from a file or, through the same row checks, a history store.

Each report is read in any supported format and tied to the model, one cycle per
machined part (a part reported in several files counts once), ordered by timestamp; the
corrections in effect at each part's timestamp (every log row with timestamp ≤ t), the
parts cut since each tool's last change and the temperature sample at or just before t
are joined to it.  A process log (read by the same reader as temperatures,
:func:`parsers.temperature.read_temperature_log` with text columns kept) is joined per
cycle by its ``serial`` column (the part's number) or else its ``timestamp`` (the row at
or just before the part): every numeric column is a channel, every categorical column a
0/1 indicator per level (one for two levels).  Used by :mod:`setupfix.pipeline.diagnose`.
"""

from __future__ import annotations

import dataclasses

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

import parsers
from parsers.corrections import RegisterLog, check_corrections, read_corrections_log
from parsers.folders import LOG_NAMES
from parsers.temperature import TemperatureLog, read_temperature_log
from parsers.timestamps import parse_timestamp, to_index
from setupfix.diagnose import Layout, Series
from setupfix.diagnose.forecast import spec_of
from setupfix.diagnose.covariates import applied_at, join_temperatures, parts_since_change
from setupfix.diagnose.terms import PRODUCT, EffectSpec, channel_values
from setupfix.errors import MatchError, Note, ParseError, SourceLocation, UnknownFormatError
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts, normalise_name
from setupfix.model.effects import EffectsSection
from setupfix.pipeline.checks import check_parts
from setupfix.pipeline.cycles import ReadOptions
from setupfix.pipeline.stores import StoreRef

__all__ = ["SeriesInput", "TempLog", "load_series", "parse_times", "hours_since", "temperature_arrays",
           "store_temperatures", "report_coordinates", "process_channels", "channel_span"]

#: A temperature log as arrays: times, samples (n, channels), channel names.
TempLog = tuple[pd.DatetimeIndex, np.ndarray, tuple[str, ...]]

#: Columns of a temperature log that are not temperature channels.
NOT_CHANNELS = ("spindle_speed",)

#: Column of a process log holding the part's number (the join key when present).
SERIAL = "serial"
#: A categorical process channel with more levels than this is left out (a note says so).
MAX_LEVELS = 8


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


def parse_times(values: Sequence[object], where: str) -> pd.DatetimeIndex:
    """The reports' part timestamps as naive datetimes (UTC when an offset is given); one clear error for a bad one.

    Read by the one timestamp parser (:func:`parsers.timestamps.parse_timestamp`), as the logs' are.
    """
    place = SourceLocation(where)
    return to_index([parse_timestamp(v, place) for v in values])


def temperature_arrays(log: TemperatureLog) -> TempLog:
    """A temperature log read by :func:`parsers.temperature.read_temperature_log` as the series' arrays.

    Every numeric column but ``spindle_speed`` is a channel; the diagnosis needs a
    timestamp column and every reading (the first empty cell is named by its line).

    Raises
    ------
    ParseError
        No timestamp column, no channel, an empty reading.
    """
    if not log.timestamps:
        raise ParseError("temperature log: missing column 'timestamp'", location=log.location(),
                         hint="the diagnosis ties each part to the sample at or before its timestamp")
    channels = tuple(c for c in log.columns if c.casefold() not in NOT_CHANNELS)
    if not channels:
        raise ParseError("temperature log: no sensor column", location=log.location())
    values = np.empty((log.n, len(channels)))
    for j, c in enumerate(channels):
        values[:, j] = log.require_finite(c, hint="the diagnosis needs every reading of a channel")
    times = to_index([parse_timestamp(t, log.location(i)) for i, t in enumerate(log.timestamps)])
    return times, values, channels


def store_temperatures(table: pd.DataFrame, source: str) -> TempLog:
    """The temperatures a history store holds (read at import by the one reader) as the series' arrays.

    A store keeps each channel's samples apart: a channel's last sample is carried
    forward (and its first one back) over the times only other channels were sampled.
    """
    where = SourceLocation(source)
    times = to_index([parse_timestamp(t, where) for t in table["timestamp"]])
    channels = tuple(str(c) for c in table.columns if c != "timestamp" and str(c).casefold() not in NOT_CHANNELS)
    if not channels:
        raise ParseError("temperature log: no sensor column", location=where)
    values = np.column_stack([pd.to_numeric(table[c], errors="coerce").ffill().bfill().to_numpy(dtype=float)
                              for c in channels])
    order = np.argsort(times.values, kind="stable")
    return times[order], values[order], channels


def _corrections(path: str, model: ProcessModel) -> RegisterLog:
    """A corrections-log file read and checked against the model (the one reader, the one check)."""
    return check_corrections(read_corrections_log(path), model)


def hours_since(times: pd.DatetimeIndex, origin: pd.Timestamp) -> np.ndarray:
    return np.asarray((times - origin).total_seconds(), dtype=float) / 3600.0


def load_series(model: ProcessModel | str | Path, reports: Sequence[str | Path] = (), *,
                corrections: str | None = None, temperatures: str | None = None,
                db: str | Path | StoreRef | None = None, thermal: str | Path | None = None,
                read: ReadOptions | None = None, process: str | None = None) -> SeriesInput:
    """Read a series of reports (files, folders, or every report of a history store) with its logs.

    With ``db`` the store's reports, corrections log and temperatures are used (files
    given as well are added; a corrections or temperature file given replaces the
    store's log).  With ``thermal`` (a model saved by ``setupfix thermal fit``) its
    predicted drift over the temperature log becomes one more channel, so the thermal
    candidate tests the thermal slice's model itself (its measured-error column is
    not used as a channel).  ``read``: the report reader's options (``lenient`` lets a
    reader skip a self-contradicting row, a note names its line).  ``process``: a process
    log (CSV or ``.xlsx``), its channels joined per cycle (:func:`process_channels`).

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
    where = StoreRef.of(db).location if db is not None else ""
    if db is not None:
        from setupfix.store import report_tables, stored_corrections

        with StoreRef.of(db).for_model(model).open() as store:
            for rec, table in report_tables(store):
                table = table[~table["reference"]]
                parts += match_parts(model, table, source=f"{where}#{rec.name}")
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
            raise ParseError("no report found", location=SourceLocation(", ".join(str(p) for p in reports)),
                             hint="; ".join(inputs.warnings()[:3]) or None)
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
        raise ParseError("no report in the series", location=SourceLocation(where or "<series>"))
    parts, more = _one_per_part(parts)
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
            raise ParseError("a thermal model needs the temperature log it predicts from",
                             location=SourceLocation(str(thermal)), hint="give --temperatures")
        temps, more_notes = _with_thermal_prediction(temps, str(thermal), temp_log)
        notes += more_notes
    process_log = None
    if process:
        process_log = read_temperature_log(process, require_time=False, keep_text=True)
        notes += process_log.notes
    series, more = _assemble(model, parts, log, temps, where, process_log)
    notes += more
    declared = tuple(spec_of(e) for e in section.effects)
    for e in section.effects:
        if e.kind == "thermal" and e.channel not in series.channels:
            raise MatchError(f"the model's thermal effect {e.id} needs temperature channel {e.channel!r}",
                             location=SourceLocation(model.source, key=f"effects.{e.id}.channel"),
                             hint="give --temperatures")
        if e.kind == "process" and not _has_channel(series, str(e.channel)):
            raise MatchError(f"the model's process effect {e.id} needs process channel {e.channel!r}",
                             location=SourceLocation(model.source, key=f"effects.{e.id}.channel"),
                             hint="give --process with the log it was found in")
    unmatched = sorted({u for p in parts for u in p.unmatched})
    if unmatched:
        notes.append(Note(f"{len(unmatched)} characteristic(s) match no dimension: {', '.join(unmatched[:6])}"
                          + (" …" if len(unmatched) > 6 else ""), None, "match"))
    layout = Layout.from_model(model, coord=report_coordinates(model, tables))
    if np.isfinite(layout.coord).all() and not all(f.position for f in model.features):
        notes.append(Note("dimension coordinates for position effects taken from the reports' x, y, z columns",
                          None, "series"))
    return SeriesInput(model, layout, series, tuple(_ordered(parts)), declared, section,
                       corrections, temperatures, tuple(notes), process)


def _has_channel(series: Series, name: str) -> bool:
    """A process channel of the series, or a product of them (a declared interaction)."""
    known = set(series.process_channels)
    return name in known or (PRODUCT in name and all(p in known for p in name.split(PRODUCT)))


def _no_log_note(reports: Sequence[str | Path]) -> str:
    """The note for a series read without a corrections log (naming a log file lying beside a report)."""
    beside = sorted({str(Path(r).parent / n) for r in reports if not Path(r).is_dir()
                     for n, kind in LOG_NAMES.items() if kind == "corrections" and (Path(r).parent / n).is_file()})
    text = ("no corrections log: every part is taken as cut with the same offsets, so a correction applied "
            "during the series would show as drift or a step")
    return text + (f"; {beside[0]} lies beside the reports: give it with --corrections" if beside else "")


def report_coordinates(model: ProcessModel, tables: Sequence[pd.DataFrame]) -> np.ndarray:
    """Nominal location (x, y, z) of each dimension as the reports give it, NaN where none does.

    Used where the model has no feature positions: a characteristic's location is the
    dimension's coordinate for a position effect.  Names repeated across stations are
    left out (their location would be ambiguous).
    """
    out = np.full((len(model.dimensions), 3), np.nan)
    index: dict[str, list[int]] = {}
    for q, dim in enumerate(model.dimensions):
        for key in dim.keys:
            index.setdefault(key, []).append(q)
    for table in tables:
        if not {"x", "y", "z", "characteristic"} <= set(table.columns):
            continue
        xyz = table[["x", "y", "z"]].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
        for name, row in zip(table["characteristic"].astype(str), xyz, strict=True):
            qs = index.get(normalise_name(name), [])
            if len(qs) == 1 and np.isfinite(row).all() and np.isnan(out[qs[0]]).all():
                out[qs[0]] = row
    return out


def _with_thermal_prediction(temps: TempLog, thermal: str, log: TemperatureLog) -> tuple[TempLog, list[Note]]:
    """The temperature channels plus the drift a saved thermal model predicts over the same log."""
    from setupfix.pipeline.thermal import predict_drift

    pred = predict_drift(thermal, log)
    times, samples, channels = temps
    keep = [j for j, c in enumerate(channels) if c != pred.target]
    name = f"{pred.method} prediction"
    notes = list(pred.notes)
    notes.append(Note(f"thermal model {thermal} ({pred.method}, {pred.unit or 'unit not stated'}): its prediction "
                      f"is the channel {name!r}", None, "thermal"))
    return (times, np.column_stack([samples[:, keep], pred.drift]), (*(channels[j] for j in keep), name)), notes


def _one_per_part(parts: list[PartMeasurement]) -> tuple[list[PartMeasurement], list[Note]]:
    """Each machined part once: reports of the same part and time (the same cycle exported twice, or
    measured twice) would count as independent cycles and make any effect look significant.

    The later one read is kept (as ``correct`` keeps a part's later measurement); the note says
    whether their deviations agree.
    """
    last: dict[tuple[str, str], int] = {}
    for i, p in enumerate(parts):
        if p.timestamp is not None:
            last[(p.part, str(p.timestamp))] = i
    notes: list[Note] = []
    keep = []
    for i, p in enumerate(parts):
        j = last[(p.part, str(p.timestamp))] if p.timestamp is not None else i
        if j == i:
            keep.append(p)
            continue
        q = parts[j]
        both = np.isfinite(p.deviation) & np.isfinite(q.deviation)
        gap = float(np.max(np.abs(p.deviation[both] - q.deviation[both]), initial=0.0))
        same = "the same deviations" if gap <= 1e-9 else f"deviations differing by up to {gap:.4g}"
        notes.append(Note(f"{p.report}:{p.part} and {q.report}:{q.part} are one part (same name and time "
                          f"{p.timestamp}, {same}): {q.report} is used once", None, "series"))
    return keep, notes


def _ordered(parts: list[PartMeasurement]) -> list[PartMeasurement]:
    if all(p.timestamp is None for p in parts) or any(p.timestamp is None for p in parts):
        return parts
    ts = parse_times([p.timestamp for p in parts], parts[0].report)
    return [parts[i] for i in np.argsort(ts.values, kind="stable")]


def _assemble(model: ProcessModel, parts: list[PartMeasurement],
              log: RegisterLog | None,
              temps: TempLog | None, where: str,
              process: TemperatureLog | None = None) -> tuple[Series, list[Note]]:
    """Parts in time order with the corrections in effect, parts since tool changes, temperatures."""
    notes: list[Note] = []
    layout = Layout.from_model(model)
    stamps = [p.timestamp for p in parts]
    if all(s is None for s in stamps) and process is not None and process.timestamps and _has_serial(process):
        # the reports carry no time: the parts were machined when the process log says (joined by serial)
        rows, _ = _process_rows(process, [p.part for p in parts], np.zeros(len(parts)), "")
        for i in rows:  # a bad one named by its line
            parse_timestamp(process.timestamps[int(i)], process.location(int(i)))
        parts = [dataclasses.replace(p, timestamp=str(process.timestamps[int(i)])) for p, i in zip(parts, rows,
                                                                                                  strict=True)]
        stamps = [p.timestamp for p in parts]
        notes.append(Note("the reports carry no timestamps: each part's machining time is the process log's "
                          "timestamp of its serial", process.location(), "series"))
    if all(s is None for s in stamps):
        if log is not None or temps is not None:
            raise MatchError("the reports carry no timestamps, so the corrections or temperature log cannot be "
                             "tied to the parts", location=SourceLocation(where), hint="add a timestamp column")
        time = np.arange(len(parts), dtype=float)
        origin = ""
        notes.append(Note("no timestamps: cycles are taken in input order, one hour apart", None, "series"))
        order = np.arange(len(parts))
    else:
        missing = [p for p in parts if p.timestamp is None]
        if missing:
            raise MatchError(f"part {missing[0].part or '(report)'} has no timestamp while others have",
                             location=SourceLocation(missing[0].report))
        ts = parse_times(stamps, parts[0].report)
        order = np.argsort(ts.values, kind="stable")
        origin_ts = ts[order[0]]
        time = hours_since(ts, origin_ts)[order]
        origin = origin_ts.isoformat()
    parts = [parts[i] for i in order]
    dev = np.vstack([p.deviation for p in parts])
    n_r = layout.n_registers
    applied = np.zeros((len(parts), n_r))
    pending = np.zeros(n_r)
    change_times: list[np.ndarray] = [np.zeros(0) for _ in layout.tools]
    if log is not None:
        times, regs, deltas, events = log.times, log.registers, log.deltas, log.events
        t_log = hours_since(times, pd.Timestamp(origin))
        is_corr = np.array([e == "correction" for e in events], dtype=bool)
        applied = applied_at(time, t_log[is_corr], regs[is_corr], deltas[is_corr], n_r)
        after = is_corr & (t_log > time[-1])
        np.add.at(pending, regs[after], deltas[after])
        for k, j in enumerate(layout.tools):
            change_times[k] = t_log[(~is_corr) & (regs == j)]
    parts_cut = parts_since_change(time, change_times)
    channels: tuple[str, ...] = ()
    temp = np.zeros((len(parts), 0))
    if temps is not None:
        t_times, samples, channels = temps
        t_h = hours_since(t_times, pd.Timestamp(origin))
        if t_h[0] > time[0]:
            notes.append(Note("the temperature log starts after the first part: its first sample is used before",
                              None, "thermal"))
        temp = join_temperatures(time, t_h, samples)
    names: tuple[str, ...] = ()
    if process is not None:
        values, names, more = process_channels(process, [p.part for p in parts], time, origin)
        notes += more
        both = sorted(set(names) & set(channels))
        if both:
            raise ParseError(f"process log: channel {both[0]!r} is also a temperature channel",
                             location=process.location(), hint="rename the column in one of the logs")
        temp = np.column_stack([temp, values])
        channels = (*channels, *names)
    series = Series(dev, time, applied, parts_cut, temp, channels, tuple(f"{p.report}:{p.part}" for p in parts),
                    origin, pending, names)
    return series, notes


def _serial_key(value: object) -> str:
    """A part number as a join key: ``7``, ``7.0`` and `` 7`` are one part."""
    text = str(value).strip()
    try:
        number = float(text)
    except ValueError:
        return text
    return str(int(number)) if number.is_integer() else text


def _has_serial(log: TemperatureLog) -> bool:
    return any(c.casefold() == SERIAL for c in (*log.columns, *log.text))


def _process_rows(log: TemperatureLog, parts: Sequence[str], time: np.ndarray,
                  origin: str) -> tuple[np.ndarray, list[Note]]:
    """Row of the process log for each cycle: by serial (the part's number), else by timestamp."""
    serial = next((c for c in (*log.columns, *log.text) if c.casefold() == SERIAL), None)
    if serial is not None:
        raw = log.columns[serial].tolist() if serial in log.columns else log.text[serial]
        index: dict[str, int] = {}
        for i, v in enumerate(raw):
            if v is None or (isinstance(v, float) and not np.isfinite(v)):
                raise ParseError("process log: empty serial", location=log.location(i))
            key = _serial_key(v)
            if key in index:
                raise ParseError(f"process log: serial {key} appears twice", location=log.location(i),
                                 hint="one row per part")
            index[key] = i
        rows = []
        for name in parts:
            key = _serial_key(name)
            if key not in index:
                raise MatchError(f"part {name or '(unnamed)'} has no row in the process log (column {serial!r})",
                                 location=log.location(), hint="give every part of the series its row")
            rows.append(index[key])
        return np.array(rows, dtype=np.intp), []
    if not log.timestamps:
        raise ParseError("process log: needs a 'serial' column (the part numbers) or a 'timestamp' column",
                         location=log.location())
    if not origin:
        raise MatchError("the reports carry no timestamps, so the process log cannot be tied to the parts by time",
                         location=log.location(), hint="add a 'serial' column with the part numbers")
    stamps = to_index([parse_timestamp(t, log.location(i)) for i, t in enumerate(log.timestamps)])
    t_h = hours_since(stamps, pd.Timestamp(origin))
    notes = []
    if t_h[0] > time[0]:
        notes.append(Note("the process log starts after the first part: its first row is used before", None,
                          "series"))
    idx = np.clip(np.searchsorted(t_h, time, side="right") - 1, 0, len(t_h) - 1)
    return idx.astype(np.intp), notes


def process_channels(log: TemperatureLog, parts: Sequence[str], time: np.ndarray,
                     origin: str) -> tuple[np.ndarray, tuple[str, ...], list[Note]]:
    """Every channel of a process log joined per cycle.

    Parameters
    ----------
    log : TemperatureLog
        Read by :func:`parsers.temperature.read_temperature_log` with ``keep_text``.
    parts : sequence of str
        Part name of each cycle (matched to a ``serial`` column).
    time : ndarray (n_cycles,) [h since ``origin``]
    origin : str
        ISO time of hour 0 ("" when the reports carry no timestamps).

    Returns
    -------
    values : ndarray (n_cycles, n_channels)
        Numeric columns as written (any unit); a categorical column as 0/1 indicators
        ``name=level``, one per level seen on at least two cycles (one indicator when
        there are two levels); the product of two categorical columns' levels as
        ``a=x & b=y`` (the interaction of a designed experiment's factors).  An indicator
        on the same cycles as a channel already kept is left out (the first name stays).
    names : tuple of str
    notes : list of Note
        Channels left out (an empty cell on a cycle, too many levels) and how rows were joined.
    """
    rows, notes = _process_rows(log, parts, time, origin)
    cols: list[np.ndarray] = []
    names: list[str] = []
    factor: list[list[tuple[str, np.ndarray]]] = []
    for name, col in log.columns.items():
        if name.casefold() == SERIAL:
            continue
        v = col[rows]
        if not np.isfinite(v).all():
            k = int(np.flatnonzero(~np.isfinite(v))[0])
            notes.append(Note(f"process channel {name!r} is empty for part {parts[k]}: left out",
                              log.location(int(rows[k])), "series"))
            continue
        cols.append(v)
        names.append(name)
    for name, cells in log.text.items():
        if name.casefold() == SERIAL:
            continue
        seen = [cells[i] for i in rows]
        if any(c is None for c in seen):
            k = seen.index(None)
            notes.append(Note(f"process channel {name!r} is empty for part {parts[k]}: left out",
                              log.location(int(rows[k])), "series"))
            continue
        counts: dict[str, int] = {}
        for c in seen:
            counts[str(c)] = counts.get(str(c), 0) + 1
        if len(counts) > MAX_LEVELS:
            notes.append(Note(f"process channel {name!r} has {len(counts)} levels (more than {MAX_LEVELS}): left out",
                              log.location(), "series"))
            continue
        levels = [lv for lv, n in counts.items() if n >= 2 and n < len(seen)]
        if len(counts) == 2:
            levels = levels[1:] if len(levels) == 2 else levels
        factor.append([(f"{name}={lv}", np.array([c == lv for c in seen], dtype=float)) for lv in levels])
    # a designed experiment's factors act together: the product of two factors' levels is a channel too
    pairs = [(f"{a} & {b}", ca * cb) for i, fa in enumerate(factor) for fb in factor[i + 1:]
             for a, ca in fa for b, cb in fb]
    seen_cols: list[np.ndarray] = list(cols)
    for lv_name, col in [*(x for f in factor for x in f), *pairs]:
        n_on = int(col.sum())
        if n_on < 2 or n_on == len(col) or any(np.array_equal(col, c) for c in seen_cols):
            continue  # one cycle, every cycle, or the same cycles as a channel already kept
        seen_cols.append(col)
        cols.append(col)
        names.append(lv_name)
    values = np.column_stack(cols) if cols else np.zeros((len(parts), 0))
    return values, tuple(names), notes


def channel_span(series: Series, spec: EffectSpec) -> float:
    """Range of a spec's channel over the series (the span a process effect was found over)."""
    return float(np.ptp(channel_values(series, str(spec.channel)))) if series.n_cycles else 0.0
