"""Read a temperature or process log (CSV or ``.xlsx``) into columns, every bad cell named.

The one reader of time-stamped logs: a temperature log (numeric sensor columns) and a
process log (``--process``: channels of any name and unit, numeric or categorical —
spindle speed, tool stick-out, feed, a designed factor's level — tied to the parts by a
``timestamp`` or a ``serial`` column).  With ``keep_text`` a text column is kept as
text (a categorical channel) instead of being left out.

A log has one column per temperature sensor (°C), optionally ``spindle_speed`` (rpm),
an ambient column and a measured thermal-error column named on the command line.
Time comes from, in this order:

1. a ``timestamp`` column (ISO 8601; Excel date cells too);
2. a sample-index column (``sample``, ``index`` or ``sample_index``) times the
   sampling interval given by the caller (``--interval SECONDS``), or numbered
   samples when no interval is given;
3. the row order times the interval given by the caller;

and without any of them the log is refused (``require_time``), because a model's
time constants are per sample.  A first row made only of numbers is data, not a
header: the columns are then named by their letters (``A``, ``B``, …, as a
spreadsheet shows them).

Cells are read with the project's one strict number parser (:mod:`parsers.numbers`,
decimal point): ``2_1``, ``nan``,
``inf`` and ``1,5`` are refused with the file and line, never read as 21 or as a
silent gap; an empty cell is a gap.  A header naming a column twice is refused (a
dropped sensor would change every prediction silently).  The file goes through the
size-limited reader of :mod:`parsers.source`; a CSV field over the csv module's
limit (131,072 characters) is refused with its line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from parsers.numbers import try_number
from parsers.source import csv_records, decode, read_bytes
from parsers.timestamps import parse_timestamp
from setupfix.core.errors import Note, ParseError, SourceLocation

__all__ = ["TemperatureLog", "read_temperature_log", "TIMESTAMP", "INDEX_COLUMNS", "strict_number"]

Array = npt.NDArray[np.float64]
TIMESTAMP = "timestamp"
#: Names of a sample-index column (case-insensitive).
INDEX_COLUMNS = ("sample", "index", "sample_index")
_ZIP = b"PK\x03\x04"


def strict_number(text: str) -> float | None:
    """A finite number written with a decimal point, else None (:func:`parsers.numbers.try_number`).

    ``2_1``, ``nan``, ``inf``, ``0x10`` and ``1,5`` are refused (Python's ``float``
    accepts the first three): in a CSV log a comma separates fields.
    """
    return try_number(text, decimal=".")


@dataclass
class TemperatureLog:
    """The numeric content of one temperature log.

    Attributes
    ----------
    source : str
        File name as given (for messages).
    columns : dict[str, ndarray]
        Every numeric column, shape (n,), NaN for an empty cell.
    seconds : ndarray or None
        Time of each sample from the first, s (None when time is counted in samples).
    timestamps : list[str]
        The timestamps as written (empty without a timestamp column).
    lines : ndarray of int
        File line (CSV) or worksheet row (xlsx) of each sample, for messages.
    sheet : str or None
        Worksheet title of an ``.xlsx`` log.
    notes : list of Note
        What was ignored or assumed while reading (warnings as data).
    text : dict[str, list of (str or None)]
        Text columns (categorical channels) when read with ``keep_text``; None for an empty cell.
    """

    source: str
    columns: dict[str, Array]
    seconds: Array | None = None
    timestamps: list[str] = field(default_factory=list)
    lines: npt.NDArray[np.int64] | None = None
    sheet: str | None = None
    notes: list[Note] = field(default_factory=list)
    text: dict[str, list[str | None]] = field(default_factory=dict)

    @property
    def n(self) -> int:
        if self.columns:
            return len(next(iter(self.columns.values())))
        return len(next(iter(self.text.values()))) if self.text else 0

    @property
    def sample_interval_s(self) -> float | None:
        """Median sampling interval in seconds (None without time)."""
        if self.seconds is None or self.seconds.size < 2:
            return None
        return float(np.median(np.diff(self.seconds)))

    def location(self, sample: int | None = None) -> SourceLocation:
        """Where sample ``sample`` is (the header without one)."""
        line = 1 if sample is None or self.lines is None else int(self.lines[sample])
        if self.sheet is not None:
            return SourceLocation(self.source, element=f"{self.sheet}!{line}")
        return SourceLocation(self.source, line=line)

    def column(self, name: str) -> Array:
        """One numeric column; :class:`ParseError` naming the file when it is absent."""
        if name not in self.columns:
            raise ParseError(
                f"no numeric column {name!r}",
                location=self.location(),
                hint=f"numeric columns: {', '.join(self.columns) or 'none'}",
            )
        return self.columns[name]

    def require_finite(
        self, name: str, *, hint: str = "this model needs every reading; only the kalman model tolerates gaps"
    ) -> Array:
        """A column without empty cells; the first empty one is named by its line."""
        values = self.column(name)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ParseError(f"empty value in column {name!r}", location=self.location(int(bad[0])), hint=hint)
        return values

    def head(self, stop: int) -> TemperatureLog:
        """The first ``stop`` samples (a training split)."""
        return self.slice(0, stop)

    def slice(self, start: int, stop: int) -> TemperatureLog:
        """Samples ``start:stop`` as a log of its own (times re-based on its first sample)."""
        secs = None if self.seconds is None else self.seconds[start:stop] - self.seconds[start]
        return TemperatureLog(
            self.source,
            {k: v[start:stop] for k, v in self.columns.items()},
            secs,
            self.timestamps[start:stop],
            None if self.lines is None else self.lines[start:stop],
            self.sheet,
            list(self.notes),
            {k: v[start:stop] for k, v in self.text.items()},
        )

    @classmethod
    def from_arrays(
        cls, source: str, columns: dict[str, npt.ArrayLike], seconds: npt.ArrayLike | None = None
    ) -> TemperatureLog:
        """A log built in memory (simulations, data without timestamps)."""
        cols = {k: np.asarray(v, dtype=float) for k, v in columns.items()}
        n = len(next(iter(cols.values())))
        return cls(source, cols, None if seconds is None else np.asarray(seconds, dtype=float), [], np.arange(2, n + 2))


def _letters(j: int) -> str:
    name = ""
    j += 1
    while j:
        j, r = divmod(j - 1, 26)
        name = chr(ord("A") + r) + name
    return name


def _cell_number(cell: Any) -> float | None:
    if isinstance(cell, bool):
        return None
    if isinstance(cell, (int, float)):
        value = float(cell)
        return value if math.isfinite(value) else None
    return strict_number(str(cell))


def _grid(data: bytes, source: str, sheet: str | None) -> tuple[list[Any], list[tuple[int, list[Any]]], str | None]:
    """(header cells, [(line or row, cells)], sheet title) of a CSV or xlsx log."""
    if data.startswith(_ZIP):
        from parsers.table.reader import load_grid

        frame, sources = load_grid(source, sheet=sheet)
        title = sources[0].split("#", 1)[1].rsplit("!", 1)[0] if sources else (sheet or "")
        rows = [
            (int(s.rsplit("!", 1)[1]), list(r)) for s, r in zip(sources, frame.itertuples(index=False), strict=True)
        ]
        return list(frame.columns), rows, title
    if sheet is not None:
        raise ParseError("--sheet applies to .xlsx logs only", location=SourceLocation(source))
    text = decode(data, source)
    records = [(line, r) for line, r in csv_records(text.lstrip("\ufeff"), source)]
    if not records:
        raise ParseError("empty file", location=SourceLocation(source))
    (_, header), body = records[0], records[1:]
    return list(header), body, None


def read_temperature_log(
    path: str | Path,
    *,
    interval: float | None = None,
    require_time: bool = True,
    sheet: str | None = None,
    keep_text: bool = False,
) -> TemperatureLog:
    """Read a temperature log (CSV, or ``.xlsx`` through the table reader).

    Parameters
    ----------
    path : str or Path
    interval : float, optional
        Sampling interval in seconds for a log without a timestamp column.
    require_time : bool
        Without a timestamp, a sample-index column or ``interval``: refuse (default)
        or count the time in samples.
    sheet : str, optional
        Worksheet of an ``.xlsx`` log (default the first).
    keep_text : bool
        Keep text columns (categorical channels of a process log) in ``text`` rather than
        leaving them out with a note; a column mixing numbers and text is then text.

    Raises
    ------
    ParseError
        Unreadable or oversized file, no data, no time, a duplicated column, a bad
        timestamp, a non-numeric or non-finite cell in a numeric column — with the
        file and line (or worksheet row).
    """
    source = str(path)
    if interval is not None and not (math.isfinite(interval) and interval > 0):
        raise ParseError(
            f"sampling interval must be a positive number of seconds, got {interval!r}", location=SourceLocation(source)
        )
    raw_header, raw_body, title = _grid(read_bytes(path), source, sheet)

    def where(line: int) -> SourceLocation:
        if title is not None:
            return SourceLocation(source, element=f"{title}!{line}")
        return SourceLocation(source, line=line)

    notes: list[Note] = []
    header = ["" if h is None else str(h).strip() for h in raw_header]
    if header and all(_cell_number(h) is not None for h in header if h) and any(header):
        # No header row: the first row is data; name the columns by their letters.
        first_line = raw_body[0][0] - 1 if raw_body else 1
        raw_body = [(first_line, list(raw_header)), *raw_body]
        header = [_letters(j) for j in range(len(header))]
        notes.append(Note("no header row: columns named A, B, C … by position", where(first_line), "parse"))
    body = [(line, r) for line, r in raw_body if any(c is not None and str(c).strip() for c in r)]
    if not body:
        raise ParseError("no data rows", location=where(2))
    seen: dict[str, int] = {}
    for j, name in enumerate(header):
        if name and name.lower() in seen:
            raise ParseError(
                f"column {name!r} appears twice (columns {seen[name.lower()] + 1} and {j + 1})",
                location=where(1),
                hint="rename one: a dropped sensor would change every prediction",
            )
        if name:
            seen[name.lower()] = j
    for line, row in body:
        if len(row) > len(header) and any(c is not None and str(c).strip() for c in row[len(header) :]):
            raise ParseError(f"{len(row)} cells but {len(header)} columns in the header", location=where(line))
    lower = [h.lower() for h in header]
    t_idx = lower.index(TIMESTAMP) if TIMESTAMP in lower else None
    i_idx = next((lower.index(c) for c in INDEX_COLUMNS if c in lower), None) if t_idx is None else None
    lines = np.array([line for line, _ in body], dtype=np.int64)
    columns: dict[str, Array] = {}
    text: dict[str, list[str | None]] = {}
    for j, name in enumerate(header):
        cells = [(row[j] if j < len(row) else None) for _, row in body]
        cells = [None if c is None or (isinstance(c, str) and not c.strip()) else c for c in cells]
        if j == t_idx:
            continue
        if not name:
            if any(c is not None for c in cells):
                raise ParseError(f"column {j + 1} has values but no name", location=where(1))
            continue
        values = np.full(len(cells), np.nan)
        bad: list[int] = []
        for i, cell in enumerate(cells):
            if cell is None:
                continue
            number = _cell_number(cell)
            if number is None:
                bad.append(i)
            else:
                values[i] = number
        filled = sum(c is not None for c in cells)
        if bad and keep_text and j != i_idx:
            text[name] = [None if c is None else str(c).strip() for c in cells]
            continue
        if bad and len(bad) == filled and j != i_idx:
            notes.append(Note(f"column {name!r} is text: ignored", where(1), "parse"))
            continue  # a text column (operator notes): kept out of the numeric table
        if bad:
            i = bad[0]
            raise ParseError(
                f"non-numeric value {str(cells[i])[:30]!r} in column {name!r}",
                location=where(int(lines[i])),
                hint="numbers are written like 21.5 or 2.15e1",
            )
        columns[name] = values
    seconds: Array | None = None
    stamps: list[str] = []
    if t_idx is not None:
        raw = [row[t_idx] if t_idx < len(row) else None for _, row in body]
        for i, cell in enumerate(raw):
            if cell is None or not str(cell).strip():
                raise ParseError("empty timestamp", location=where(int(lines[i])))
        times = [parse_timestamp(c, where(int(line))) for c, line in zip(raw, lines, strict=True)]
        stamps = [t.isoformat() if isinstance(c, datetime) else str(c).strip() for c, t in zip(raw, times, strict=True)]
        try:
            seconds = np.array([(t - times[0]).total_seconds() for t in times])
        except TypeError:
            raise ParseError("timestamps mix time zones and local times", location=where(int(lines[0]))) from None
        _check_increasing(seconds, lines, where, "timestamp")
    elif i_idx is not None:
        index = columns.pop(header[i_idx])
        if not np.all(np.isfinite(index)) or np.any(index != np.round(index)):
            bad_i = int(np.flatnonzero(~np.isfinite(index) | (index != np.round(index)))[0])
            raise ParseError(f"sample index {index[bad_i]!r} is not a whole number", location=where(int(lines[bad_i])))
        _check_increasing(index, lines, where, "sample index")
        if interval is not None:
            seconds = (index - index[0]) * interval
        else:
            notes.append(Note("no timestamp and no sampling interval: time counted in samples", where(1), "parse"))
    elif interval is not None:
        seconds = np.arange(len(body), dtype=float) * interval
    elif require_time:
        raise ParseError(
            "no 'timestamp' column",
            location=where(1),
            hint="give the sampling interval with --interval SECONDS, or add a timestamp or sample column",
        )
    else:
        notes.append(Note("no timestamp: time counted in samples", where(1), "parse"))
    if not columns and not text:
        raise ParseError("no numeric columns", location=where(1))
    if seconds is not None and seconds.size > 2:
        steps = np.diff(seconds)
        med = float(np.median(steps))
        if np.max(np.abs(steps - med)) > 0.05 * med:
            notes.append(
                Note(
                    f"sampling interval varies (median {med:g} s); grey and lumped-mass models assume equal steps",
                    where(1),
                    "thermal",
                )
            )
    return TemperatureLog(source, columns, seconds, stamps, lines, title, notes, text)


def _check_increasing(values: Array, lines: npt.NDArray[np.int64], where: Any, what: str) -> None:
    back = np.flatnonzero(np.diff(values) <= 0)
    if back.size:
        raise ParseError(
            f"{what} not after the previous one",
            location=where(int(lines[back[0] + 1])),
            hint="sort the log by time and remove repeated samples",
        )
