"""The parts of a series assembled into the engine's :class:`~setupfix.diagnose.Series`.

One cycle per machined part (a part reported in several files counts once), ordered by
timestamp; the corrections in effect at each part's timestamp (every log row with timestamp
≤ t), the parts cut since each tool's last change, the temperature sample at or just before t
and the process log's channels (:mod:`setupfix.inputs.series_logs`) are joined to it.  The
dimensions' coordinates the reports give are read here too.  Used by
:mod:`setupfix.inputs.series`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import pandas as pd

from parsers.corrections import RegisterLog
from parsers.temperature import TemperatureLog
from parsers.timestamps import parse_timestamp
from setupfix.core.errors import MatchError, Note, ParseError, SourceLocation
from setupfix.diagnose import Layout, Series
from setupfix.diagnose.covariates import applied_at, join_temperatures, parts_since_change
from setupfix.inputs.duplicates import ContentIndex, part_content
from setupfix.inputs.series_logs import (
    TempLog,
    has_serial,
    hours_since,
    parse_times,
    process_channels,
    process_rows,
)
from setupfix.model import PartMeasurement, ProcessModel, normalise_name

__all__ = ["report_coordinates"]


def report_coordinates(model: ProcessModel, tables: Sequence[pd.DataFrame]) -> np.ndarray:
    """Nominal location (x, y, z) of each dimension as the reports give it, NaN where none does.

    Used where the model has no feature positions: a characteristic's location is the
    dimension's coordinate for a position effect.  Names repeated across stations are
    left out (their location would be ambiguous).  The first row (tables in order, rows in
    order) naming the dimension with all three coordinates readable gives it.

    Returns
    -------
    ndarray of shape (n_dimensions, 3) [the reports' length unit]
    """
    out = np.full((len(model.dimensions), 3), np.nan)
    index: dict[str, list[int]] = {}
    for q, dim in enumerate(model.dimensions):
        for key in dim.keys:
            index.setdefault(key, []).append(q)
    names: list[np.ndarray] = []
    coords: list[np.ndarray] = []
    for table in tables:
        if not {"x", "y", "z", "characteristic"} <= set(table.columns):
            continue
        names.append(table["characteristic"].astype(str).to_numpy(dtype=object))
        coords.append(np.column_stack([pd.to_numeric(table[c], errors="coerce").to_numpy(dtype=float) for c in "xyz"]))
    if not names:
        return out
    name = np.concatenate(names)
    xyz = np.concatenate(coords)
    unique, inverse = np.unique(name.astype(str), return_inverse=True)
    single = [index.get(normalise_name(str(u)), []) for u in unique]
    dim_of = np.array([qs[0] if len(qs) == 1 else -1 for qs in single], dtype=np.int64)[inverse.reshape(-1)]
    rows = np.flatnonzero((dim_of >= 0) & np.isfinite(xyz).all(axis=1))
    dims, first = np.unique(dim_of[rows], return_index=True)
    out[dims] = xyz[rows[first]]
    return out


def one_per_part(parts: list[PartMeasurement]) -> tuple[list[PartMeasurement], list[Note]]:
    """Each machined part once: reports of the same part (the same cycle exported twice or in
    another format, or measured twice) would count as independent cycles and make any effect
    look significant.

    Two parts are one when they have the same name and time as written, or are the same
    measurement (:func:`setupfix.inputs.duplicates.same_measurement`: name up to case and
    spacing, time, values to the reports' resolution, at most one row missing).  The later
    one read is kept (as ``correct`` keeps a part's later measurement); the note says whether
    their deviations agree.
    """
    keys = [str(q) for q in range(len(parts[0].deviation))] if parts else []
    index = ContentIndex()
    slot_of: list[int] = []  # position in ``index`` → slot
    by_stamp: dict[tuple[str, str], int] = {}
    kept: list[int] = []  # slot → the part kept (the latest read)
    first: list[int] = []  # part → its slot
    for i, p in enumerate(parts):
        c = part_content(p, keys, unreadable_time=True)  # refused by the series' own time reading, named there
        slot = by_stamp.get((p.part, str(p.timestamp))) if p.timestamp is not None else None
        if slot is None:
            j = index.find(c)
            slot = slot_of[j] if j is not None else None
        if slot is None:
            slot = len(kept)
            kept.append(i)
        else:
            kept[slot] = i
        index.add(c)
        slot_of.append(slot)
        first.append(slot)
        if p.timestamp is not None:
            by_stamp[(p.part, str(p.timestamp))] = slot
    notes: list[Note] = []
    for i, p in enumerate(parts):
        q = parts[kept[first[i]]]
        if q is p:
            continue
        both = np.isfinite(p.deviation) & np.isfinite(q.deviation)
        gap = float(np.max(np.abs(p.deviation[both] - q.deviation[both]), initial=0.0))
        same = "the same deviations" if gap <= 1e-9 else f"deviations differing by up to {gap:.4g}"
        how = (
            f"same name and time {p.timestamp}"
            if p.timestamp is not None and (p.part, p.timestamp) == (q.part, q.timestamp)
            else "the same measurement: name up to case and spacing, time, values to the reports' resolution"
        )
        notes.append(
            Note(
                f"{p.report}:{p.part} and {q.report}:{q.part} are one part ({how}, {same}): {q.report} is used once",
                None,
                "series",
            )
        )
    return [parts[i] for i in sorted(kept)], notes


def ordered_parts(parts: list[PartMeasurement]) -> list[PartMeasurement]:
    if all(p.timestamp is None for p in parts) or any(p.timestamp is None for p in parts):
        return parts
    ts = parse_times([p.timestamp for p in parts], parts[0].report)
    return [parts[i] for i in np.argsort(ts.values, kind="stable")]


def assemble(
    model: ProcessModel,
    parts: list[PartMeasurement],
    log: RegisterLog | None,
    temps: TempLog | None,
    where: str,
    process: TemperatureLog | None = None,
) -> tuple[Series, list[Note]]:
    """Parts in time order with the corrections in effect, parts since tool changes, temperatures."""
    notes: list[Note] = []
    layout = Layout.from_model(model)
    stamps = [p.timestamp for p in parts]
    if all(s is None for s in stamps) and process is not None and process.timestamps and has_serial(process):
        # the reports carry no time: the parts were machined when the process log says (joined by serial)
        rows, _ = process_rows(process, [p.part for p in parts], np.zeros(len(parts)), "")
        for i in rows:  # a bad one named by its line
            parse_timestamp(process.timestamps[int(i)], process.location(int(i)))
        parts = [
            dataclasses.replace(p, timestamp=str(process.timestamps[int(i)])) for p, i in zip(parts, rows, strict=True)
        ]
        stamps = [p.timestamp for p in parts]
        notes.append(
            Note(
                "the reports carry no timestamps: each part's machining time is the process log's "
                "timestamp of its serial",
                process.location(),
                "series",
            )
        )
    if all(s is None for s in stamps):
        if log is not None or temps is not None:
            raise MatchError(
                "the reports carry no timestamps, so the corrections or temperature log cannot be tied to the parts",
                location=SourceLocation(where),
                hint="add a timestamp column",
            )
        time = np.arange(len(parts), dtype=float)
        origin = ""
        notes.append(Note("no timestamps: cycles are taken in input order, one hour apart", None, "series"))
        order = np.arange(len(parts))
    else:
        missing = [p for p in parts if p.timestamp is None]
        if missing:
            raise MatchError(
                f"part {missing[0].part or '(report)'} has no timestamp while others have",
                location=SourceLocation(missing[0].report),
            )
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
            notes.append(
                Note(
                    "the temperature log starts after the first part: its first sample is used before", None, "thermal"
                )
            )
        temp = join_temperatures(time, t_h, samples)
    names: tuple[str, ...] = ()
    if process is not None:
        values, names, more = process_channels(process, [p.part for p in parts], time, origin)
        notes += more
        both = sorted(set(names) & set(channels))
        if both:
            raise ParseError(
                f"process log: channel {both[0]!r} is also a temperature channel",
                location=process.location(),
                hint="rename the column in one of the logs",
            )
        temp = np.column_stack([temp, values])
        channels = (*channels, *names)
    series = Series(
        dev,
        time,
        applied,
        parts_cut,
        temp,
        channels,
        tuple(f"{p.report}:{p.part}" for p in parts),
        origin,
        pending,
        names,
    )
    return series, notes
