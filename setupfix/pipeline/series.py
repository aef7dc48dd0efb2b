"""Reading a series for the diagnosis: reports (files, folders or a history store), the
corrections log and the temperature log → the engine's :class:`~setupfix.diagnose.Series`.

Each report is read in any supported format and tied to the model, one cycle per
machined part (a part reported in several files counts once), ordered by timestamp; the
corrections in effect at each part's timestamp (every log row with timestamp ≤ t), the
parts cut since each tool's last change and the temperature sample at or just before t
are joined to it.  Used by :mod:`setupfix.pipeline.diagnose`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

import parsers
from setupfix.diagnose import Layout, Series
from setupfix.diagnose.forecast import spec_of
from setupfix.diagnose.terms import EffectSpec, applied_at, join_temperatures, parts_since_change
from setupfix.errors import MatchError, ParseError, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts, normalise_name
from setupfix.model.effects import EffectsSection, model_effects
from setupfix.pipeline.checks import check_parts

__all__ = ["SeriesInput", "TempLog", "load_series", "parse_times", "hours_since", "read_corrections_log", "read_temperature_log", "expand_reports",
           "corrections_from_table", "temperatures_from_table", "report_coordinates"]

#: A temperature log as arrays: times, samples (n, channels), channel names.
TempLog = tuple[pd.DatetimeIndex, np.ndarray, tuple[str, ...]]

_LOG_NAMES = ("corrections.csv",)
_TEMP_NAMES = ("temperatures.csv",)
_SKIP = {"truth.json", "readme.md", "readme.txt", "provenance.md", "sources.md"}


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
    notes: tuple[str, ...] = ()


def expand_reports(paths: Sequence[str | Path]) -> tuple[list[Path], str | None, str | None, list[str]]:
    """Files of the given paths (folders recursively, sorted); logs found in folders apart.

    Returns
    -------
    reports, corrections, temperatures, notes
        ``corrections.csv`` / ``temperatures.csv`` found in a folder are returned
        apart (and said in the notes), never read as reports.
    """
    known = {ext for spec in parsers.formats() for ext in spec.extensions}
    out: list[Path] = []
    corrections = temperatures = None
    notes: list[str] = []
    for p in paths:
        path = Path(p)
        if path.is_dir():
            for f in sorted(q for q in path.rglob("*") if q.is_file()):
                name = f.name.lower()
                if name in _LOG_NAMES:
                    corrections = corrections or str(f)
                elif name in _TEMP_NAMES:
                    temperatures = temperatures or str(f)
                elif name not in _SKIP and f.suffix.lower() in known:
                    out.append(f)
        elif path.exists():
            out.append(path)
        else:
            raise ParseError("no such file or folder", location=SourceLocation(str(path)))
    if not out:
        raise ParseError("no report found", location=SourceLocation(", ".join(str(p) for p in paths)))
    return out, corrections, temperatures, notes


def parse_times(values: Sequence[object], where: str, lines: Sequence[int] | None = None) -> pd.DatetimeIndex:
    """ISO 8601 timestamps as naive UTC-free datetimes; one clear error for a bad one."""
    out = []
    for i, v in enumerate(values):
        try:
            t = pd.Timestamp(str(v))
            if pd.isna(t):
                raise ValueError
        except (ValueError, TypeError):
            line = lines[i] if lines is not None else None
            raise ParseError(f"not an ISO 8601 timestamp: {v!r}", location=SourceLocation(where, line=line)) from None
        if t.tzinfo is not None:
            t = t.tz_convert("UTC").tz_localize(None)
        out.append(t)
    return pd.DatetimeIndex(out)


def _read_csv(path: str) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False, encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise ParseError(f"cannot read CSV: {exc}", location=SourceLocation(path)) from None
    table.columns = [str(c).strip() for c in table.columns]
    return table


def read_corrections_log(path: str, model: ProcessModel) -> tuple[pd.DatetimeIndex, np.ndarray, np.ndarray, list[str]]:
    """Read a corrections log (``measurements.md``): times, register rows, deltas, events.

    Raises
    ------
    ParseError
        Missing column, bad timestamp or delta (with the line).
    MatchError
        Unknown register, or a tool change of a register that is not a tool.
    """
    return corrections_from_table(_read_csv(path), model, path)


def corrections_from_table(table: pd.DataFrame, model: ProcessModel,
                           path: str) -> tuple[pd.DatetimeIndex, np.ndarray, np.ndarray, list[str]]:
    """A corrections-log table (CSV or store) checked against the model; see :func:`read_corrections_log`."""
    table = table.astype(object).where(table.notna(), "").astype(str)
    for col in ("timestamp", "register"):
        if col not in table:
            raise ParseError(f"corrections log: missing column {col!r}", location=SourceLocation(path, line=1))
    if "delta" not in table:
        raise ParseError("corrections log: missing column 'delta'", location=SourceLocation(path, line=1))
    lines = [i + 2 for i in range(len(table))]
    times = parse_times(table["timestamp"].tolist(), path, lines)
    regs: list[int] = []
    deltas: list[float] = []
    events: list[str] = []
    ids = model.register_ids
    records: list[dict[str, str]] = table.to_dict("records")  # type: ignore[assignment]
    for i, rec in enumerate(records):
        event = str(rec.get("event") or "correction").strip() or "correction"
        if event not in ("correction", "tool_change"):
            raise ParseError(f"unknown event {event!r} (expected correction or tool_change)",
                             location=SourceLocation(path, line=lines[i]))
        try:
            reg = model.register(str(rec["register"]))
        except KeyError:
            raise MatchError(f"unknown register {rec['register']!r} (model registers: {', '.join(ids)})",
                             location=SourceLocation(path, line=lines[i])) from None
        if event == "tool_change" and reg.kind != "tool":
            raise MatchError(f"tool change of {reg.id}, which is not a tool",
                             location=SourceLocation(path, line=lines[i]))
        text = str(rec["delta"]).strip()
        if event == "correction":
            try:
                delta = float(text)
                if not math.isfinite(delta):
                    raise ValueError
            except ValueError:
                raise ParseError(f"delta {text!r} is not a number",
                                 location=SourceLocation(path, line=lines[i])) from None
        else:
            delta = 0.0
        regs.append(ids.index(reg.id))
        deltas.append(delta)
        events.append(event)
    return times, np.array(regs, dtype=np.intp), np.array(deltas, dtype=float), events


def read_temperature_log(path: str) -> tuple[pd.DatetimeIndex, np.ndarray, tuple[str, ...]]:
    """Read a temperature log: times, samples (n, channels), channel names (all numeric columns but
    the timestamp and spindle_speed).

    Raises
    ------
    ParseError
        Missing timestamp column, no sensor column, bad timestamp or value.
    """
    return temperatures_from_table(_read_csv(path), path)


def temperatures_from_table(table: pd.DataFrame, path: str, *,
                            fill: bool = False) -> tuple[pd.DatetimeIndex, np.ndarray, tuple[str, ...]]:
    """A temperature-log table (CSV or store); ``fill`` carries a channel's last sample forward
    (a store holds each channel's samples apart)."""
    if "timestamp" not in table:
        raise ParseError("temperature log: missing column 'timestamp'", location=SourceLocation(path, line=1))
    lines = [i + 2 for i in range(len(table))]
    times = parse_times(table["timestamp"].tolist(), path, lines)
    channels = tuple(c for c in table.columns if c not in ("timestamp", "spindle_speed"))
    if not channels:
        raise ParseError("temperature log: no sensor column", location=SourceLocation(path, line=1))
    values = np.empty((len(table), len(channels)))
    for j, c in enumerate(channels):
        num = pd.to_numeric(table[c], errors="coerce")
        col = (num.ffill().bfill() if fill else num).to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise ParseError(f"temperature {table[c].iloc[bad[0]]!r} in column {c!r} is not a number",
                             location=SourceLocation(path, line=lines[bad[0]]))
        values[:, j] = col
    order = np.argsort(times.values, kind="stable")
    return times[order], values[order], channels


def hours_since(times: pd.DatetimeIndex, origin: pd.Timestamp) -> np.ndarray:
    return np.asarray((times - origin).total_seconds(), dtype=float) / 3600.0


def load_series(model: ProcessModel | str | Path, reports: Sequence[str | Path] = (), *,
                corrections: str | None = None, temperatures: str | None = None,
                db: str | Path | None = None, thermal: str | Path | None = None,
                lenient: bool = False) -> SeriesInput:
    """Read a series of reports (files, folders, or every report of a history store) with its logs.

    With ``db`` the store's reports, corrections log and temperatures are used (files
    given as well are added; a corrections or temperature file given replaces the
    store's log).  With ``thermal`` (a model saved by ``setupfix thermal fit``) its
    predicted drift over the temperature log becomes one more channel, so the thermal
    candidate tests the thermal slice's model itself (its measured-error column is
    not used as a channel).  ``lenient`` lets a reader skip a self-contradicting row (a
    note names its line).

    Raises
    ------
    SetupfixError
        Any unreadable or unmatchable file, naming it and the place.
    """
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    section = model_effects(model)
    notes: list[str] = []
    parts: list[PartMeasurement] = []
    tables: list[pd.DataFrame] = []
    log = temps = None
    where = str(db) if db is not None else ""
    if db is not None:
        from setupfix.store import open_store

        if not Path(db).is_file():
            raise ParseError("no such history store", location=SourceLocation(str(db)),
                             hint="create it with 'setupfix history import'")
        with open_store(db) as store:
            rows = store.measurements()
            for rec in store.reports():
                table = rows[rows["report_sha256"] == rec.sha256].drop(columns=["report_sha256"])
                table = table[~table["reference"]] if "reference" in table else table
                parts += match_parts(model, table, source=f"{db}#{rec.name}")
                tables.append(table)
            if corrections is None:
                stored = store.corrections()
                if not stored.empty:
                    log = corrections_from_table(stored, model, f"{db}#corrections")
            if temperatures is None:
                stored_t = store.temperatures()
                if len(stored_t.columns) > 1 and not stored_t.empty:
                    temps = temperatures_from_table(stored_t, f"{db}#temperatures", fill=True)
    if reports:
        files, found_log, found_temp, more = expand_reports(reports)
        notes += more
        where = where or str(files[0])
        if corrections is None and found_log and log is None:
            corrections = found_log
            notes.append(f"corrections log {found_log} found beside the reports: used")
        if temperatures is None and found_temp and temps is None:
            temperatures = found_temp
            notes.append(f"temperature log {found_temp} found beside the reports: used")
        for f in files:
            read = parsers.read_report(f, lenient=lenient)
            table = read.table
            notes += [str(n) for n in read.notes]
            parts += check_parts(model, match_parts(model, table, source=str(f)), source=str(f))
            tables.append(table)
    if not parts:
        raise ParseError("no report in the series", location=SourceLocation(where or "<series>"))
    parts, more = _one_per_part(parts)
    notes += more
    if not corrections and log is None and len(parts) > 1:
        notes.append(_no_log_note(reports))
    if corrections:
        log = read_corrections_log(corrections, model)
    if temperatures:
        temps = read_temperature_log(temperatures)
    if thermal is not None:
        if not temperatures:
            raise ParseError("a thermal model needs the temperature log it predicts from",
                             location=SourceLocation(str(thermal)), hint="give --temperatures")
        temps, more_notes = _with_thermal_prediction(temps, str(thermal), str(temperatures))
        notes += more_notes
    series, more = _assemble(model, parts, log, temps, where)
    notes += more
    declared = tuple(spec_of(e) for e in section.effects)
    for e in section.effects:
        if e.kind == "thermal" and e.channel not in series.channels:
            raise MatchError(f"the model's thermal effect {e.id} needs temperature channel {e.channel!r}",
                             location=SourceLocation(model.source, key=f"effects.{e.id}.channel"),
                             hint="give --temperatures")
    unmatched = sorted({u for p in parts for u in p.unmatched})
    if unmatched:
        notes.append(f"{len(unmatched)} characteristic(s) match no dimension: {', '.join(unmatched[:6])}"
                     + (" …" if len(unmatched) > 6 else ""))
    layout = Layout.from_model(model, coord=report_coordinates(model, tables))
    if np.isfinite(layout.coord).all() and not all(f.position for f in model.features):
        notes.append("dimension coordinates for position effects taken from the reports' x, y, z columns")
    return SeriesInput(model, layout, series, tuple(_ordered(parts)), declared, section,
                       corrections, temperatures, tuple(notes))


def _no_log_note(reports: Sequence[str | Path]) -> str:
    """The note for a series read without a corrections log (naming a log file lying beside a report)."""
    beside = sorted({str(Path(r).parent / n) for r in reports if not Path(r).is_dir()
                     for n in _LOG_NAMES if (Path(r).parent / n).is_file()})
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
        for name, row in zip(table["characteristic"].astype(str), xyz):
            qs = index.get(normalise_name(name), [])
            if len(qs) == 1 and np.isfinite(row).all() and np.isnan(out[qs[0]]).all():
                out[qs[0]] = row
    return out


def _with_thermal_prediction(temps: TempLog | None, thermal: str, temperatures: str) -> tuple[TempLog, list[str]]:
    """The temperature channels plus the drift a saved thermal model predicts over the same log."""
    from setupfix.pipeline.thermal import predict_drift

    assert temps is not None
    pred = predict_drift(thermal, temperatures)
    times, samples, channels = temps
    p_times = parse_times(pred.timestamps, temperatures)
    idx = np.clip(np.searchsorted(p_times.values, times.values, side="right") - 1, 0, len(p_times) - 1)
    keep = [j for j, c in enumerate(channels) if c != pred.target]
    name = f"{pred.method} prediction"
    notes = [str(n) for n in pred.notes]
    notes.append(f"thermal model {thermal} ({pred.method}, {pred.unit or 'unit not stated'}): its prediction is "
                 f"the channel {name!r}")
    return (times, np.column_stack([samples[:, keep], pred.drift[idx]]),
            (*(channels[j] for j in keep), name)), notes


def _one_per_part(parts: list[PartMeasurement]) -> tuple[list[PartMeasurement], list[str]]:
    """Each machined part once: reports of the same part and time (the same cycle exported twice, or
    measured twice) would count as independent cycles and make any effect look significant.

    The later one read is kept (as ``correct`` keeps a part's later measurement); the note says
    whether their deviations agree.
    """
    last: dict[tuple[str, str], int] = {}
    for i, p in enumerate(parts):
        if p.timestamp is not None:
            last[(p.part, str(p.timestamp))] = i
    notes: list[str] = []
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
        notes.append(f"{p.report}:{p.part} and {q.report}:{q.part} are one part (same name and time {p.timestamp}, "
                     f"{same}): {q.report} is used once")
    return keep, notes


def _ordered(parts: list[PartMeasurement]) -> list[PartMeasurement]:
    if all(p.timestamp is None for p in parts) or any(p.timestamp is None for p in parts):
        return parts
    ts = parse_times([p.timestamp for p in parts], parts[0].report)
    return [parts[i] for i in np.argsort(ts.values, kind="stable")]


def _assemble(model: ProcessModel, parts: list[PartMeasurement],
              log: tuple[pd.DatetimeIndex, np.ndarray, np.ndarray, list[str]] | None,
              temps: TempLog | None, where: str) -> tuple[Series, list[str]]:
    """Parts in time order with the corrections in effect, parts since tool changes, temperatures."""
    notes: list[str] = []
    layout = Layout.from_model(model)
    stamps = [p.timestamp for p in parts]
    if all(s is None for s in stamps):
        if log is not None or temps is not None:
            raise MatchError("the reports carry no timestamps, so the corrections or temperature log cannot be "
                             "tied to the parts", location=SourceLocation(where), hint="add a timestamp column")
        time = np.arange(len(parts), dtype=float)
        origin = ""
        notes.append("no timestamps: cycles are taken in input order, one hour apart")
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
        times, regs, deltas, events = log
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
            notes.append("the temperature log starts after the first part: its first sample is used before")
        temp = join_temperatures(time, t_h, samples)
    series = Series(dev, time, applied, parts_cut, temp, channels, tuple(f"{p.report}:{p.part}" for p in parts),
                    origin, pending)
    return series, notes
