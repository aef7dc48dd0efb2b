"""The logs joined to a series' cycles, as arrays: the time axis, the temperature log and the process log.

The temperature log, from a file (read by :func:`parsers.temperature.read_temperature_log`) or a history
store, becomes times, samples and channel names (:data:`TempLog`); every numeric column but
``spindle_speed`` is a channel.  A process log (read by the same reader with text columns kept) is joined
per cycle by its ``serial`` column (the part's number) or else its ``timestamp`` (the row at or just
before the part): every numeric column is a channel, every categorical column a 0/1 indicator per level
(one for two levels).  Timestamps are read by the one parser (:mod:`parsers.timestamps`).  Used by
:mod:`setupfix.inputs.series_assembly` and :mod:`setupfix.inputs.series`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from parsers.temperature import TemperatureLog
from parsers.timestamps import parse_timestamp, to_index
from setupfix.core.errors import MatchError, Note, ParseError, SourceLocation

__all__ = ["TempLog", "parse_times", "hours_since", "temperature_arrays", "store_temperatures", "process_channels"]

#: A temperature log as arrays: times, samples (n, channels), channel names.
TempLog = tuple[pd.DatetimeIndex, np.ndarray, tuple[str, ...]]

#: Columns of a temperature log that are not temperature channels.
NOT_CHANNELS = ("spindle_speed",)

#: Column of a process log holding the part's number (the join key when present).
SERIAL = "serial"
#: A categorical process channel with more levels than this is left out (a note says so).
MAX_LEVELS = 8


def parse_times(values: Sequence[object], where: str) -> pd.DatetimeIndex:
    """The reports' part timestamps as naive datetimes (UTC when an offset is given); one clear error for a bad one.

    Read by the one timestamp parser (:func:`parsers.timestamps.parse_timestamp`), as the logs' are.
    """
    place = SourceLocation(where)
    return to_index([parse_timestamp(v, place) for v in values])


def hours_since(times: pd.DatetimeIndex, origin: pd.Timestamp) -> np.ndarray:
    return np.asarray((times - origin).total_seconds(), dtype=float) / 3600.0


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
        raise ParseError(
            "temperature log: missing column 'timestamp'",
            location=log.location(),
            hint="the diagnosis ties each part to the sample at or before its timestamp",
        )
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
    values = np.column_stack(
        [pd.to_numeric(table[c], errors="coerce").ffill().bfill().to_numpy(dtype=float) for c in channels]
    )
    order = np.argsort(times.values, kind="stable")
    return times[order], values[order], channels


def _serial_key(value: object) -> str:
    """A part number as a join key: ``7``, ``7.0`` and `` 7`` are one part."""
    text = str(value).strip()
    try:
        number = float(text)
    except ValueError:
        return text
    return str(int(number)) if number.is_integer() else text


def has_serial(log: TemperatureLog) -> bool:
    return any(c.casefold() == SERIAL for c in (*log.columns, *log.text))


def process_rows(
    log: TemperatureLog, parts: Sequence[str], time: np.ndarray, origin: str
) -> tuple[np.ndarray, list[Note]]:
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
                raise ParseError(
                    f"process log: serial {key} appears twice", location=log.location(i), hint="one row per part"
                )
            index[key] = i
        rows = []
        for name in parts:
            key = _serial_key(name)
            if key not in index:
                raise MatchError(
                    f"part {name or '(unnamed)'} has no row in the process log (column {serial!r})",
                    location=log.location(),
                    hint="give every part of the series its row",
                )
            rows.append(index[key])
        return np.array(rows, dtype=np.intp), []
    if not log.timestamps:
        raise ParseError(
            "process log: needs a 'serial' column (the part numbers) or a 'timestamp' column", location=log.location()
        )
    if not origin:
        raise MatchError(
            "the reports carry no timestamps, so the process log cannot be tied to the parts by time",
            location=log.location(),
            hint="add a 'serial' column with the part numbers",
        )
    stamps = to_index([parse_timestamp(t, log.location(i)) for i, t in enumerate(log.timestamps)])
    t_h = hours_since(stamps, pd.Timestamp(origin))
    notes = []
    if t_h[0] > time[0]:
        notes.append(Note("the process log starts after the first part: its first row is used before", None, "series"))
    idx = np.clip(np.searchsorted(t_h, time, side="right") - 1, 0, len(t_h) - 1)
    return idx.astype(np.intp), notes


def process_channels(
    log: TemperatureLog, parts: Sequence[str], time: np.ndarray, origin: str
) -> tuple[np.ndarray, tuple[str, ...], list[Note]]:
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
    rows, notes = process_rows(log, parts, time, origin)
    cols: list[np.ndarray] = []
    names: list[str] = []
    factor: list[list[tuple[str, np.ndarray]]] = []
    for name, col in log.columns.items():
        if name.casefold() == SERIAL:
            continue
        v = col[rows]
        if not np.isfinite(v).all():
            k = int(np.flatnonzero(~np.isfinite(v))[0])
            notes.append(
                Note(
                    f"process channel {name!r} is empty for part {parts[k]}: left out",
                    log.location(int(rows[k])),
                    "series",
                )
            )
            continue
        cols.append(v)
        names.append(name)
    for name, cells in log.text.items():
        if name.casefold() == SERIAL:
            continue
        seen = [cells[i] for i in rows]
        if any(c is None for c in seen):
            k = seen.index(None)
            notes.append(
                Note(
                    f"process channel {name!r} is empty for part {parts[k]}: left out",
                    log.location(int(rows[k])),
                    "series",
                )
            )
            continue
        counts: dict[str, int] = {}
        for c in seen:
            counts[str(c)] = counts.get(str(c), 0) + 1
        if len(counts) > MAX_LEVELS:
            notes.append(
                Note(
                    f"process channel {name!r} has {len(counts)} levels (more than {MAX_LEVELS}): left out",
                    log.location(),
                    "series",
                )
            )
            continue
        levels = [lv for lv, n in counts.items() if n >= 2 and n < len(seen)]
        if len(counts) == 2:
            levels = levels[1:] if len(levels) == 2 else levels
        factor.append([(f"{name}={lv}", np.array([c == lv for c in seen], dtype=float)) for lv in levels])
    # a designed experiment's factors act together: the product of two factors' levels is a channel too
    pairs = [
        (f"{a} & {b}", ca * cb) for i, fa in enumerate(factor) for fb in factor[i + 1 :] for a, ca in fa for b, cb in fb
    ]
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
