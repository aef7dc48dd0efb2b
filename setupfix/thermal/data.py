"""Temperature logs (``spec/measurements.md``, "Temperature log") read into arrays.

A log is a CSV with a ``timestamp`` column (ISO 8601), one column per temperature
sensor (°C), optionally ``spindle_speed`` (rpm) and a measured thermal-error column
named on the command line.  Columns may come in any order; a column whose cells are
all non-numeric (an operator note, say) is ignored unless it is asked for.  Every
bad cell is reported with the file and the line it is on.
"""

from __future__ import annotations

import csv
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np
import numpy.typing as npt

from setupfix.errors import ParseError, ParseWarning, SourceLocation

__all__ = ["TemperatureLog", "read_temperature_log", "Selection", "select_columns"]

Array = npt.NDArray[np.float64]
TIMESTAMP = "timestamp"
SPEED = "spindle_speed"
AMBIENT = "ambient"


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
        Time of each sample from the first, s (None without a timestamp column).
    timestamps : list[str]
        The timestamps as written.
    lines : ndarray of int
        File line of each sample (for messages).
    """

    source: str
    columns: dict[str, Array]
    seconds: Array | None = None
    timestamps: list[str] = field(default_factory=list)
    lines: npt.NDArray[np.int64] | None = None

    @property
    def n(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def sample_interval_s(self) -> float | None:
        """Median sampling interval in seconds (None without timestamps)."""
        if self.seconds is None or self.seconds.size < 2:
            return None
        return float(np.median(np.diff(self.seconds)))

    def column(self, name: str) -> Array:
        """One numeric column; :class:`ParseError` naming the file when it is absent."""
        if name not in self.columns:
            raise ParseError(f"no numeric column {name!r}", location=SourceLocation(self.source, line=1),
                             hint=f"numeric columns: {', '.join(self.columns) or 'none'}")
        return self.columns[name]

    def require_finite(self, name: str) -> Array:
        """A column without empty cells; the first empty one is named by its line."""
        values = self.column(name)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            line = int(self.lines[bad[0]]) if self.lines is not None else None
            raise ParseError(f"empty value in column {name!r}", location=SourceLocation(self.source, line=line),
                             hint="this model needs every reading; only the kalman model tolerates gaps")
        return values

    @classmethod
    def from_arrays(cls, source: str, columns: dict[str, npt.ArrayLike],
                    seconds: npt.ArrayLike | None = None) -> TemperatureLog:
        """A log built in memory (simulations, data without timestamps)."""
        cols = {k: np.asarray(v, dtype=float) for k, v in columns.items()}
        n = len(next(iter(cols.values())))
        return cls(source, cols, None if seconds is None else np.asarray(seconds, dtype=float), [],
                   np.arange(2, n + 2))


def _parse_time(text: str, source: str, line: int) -> datetime:
    try:
        stamp = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ParseError(f"timestamp {text!r} is not ISO 8601", location=SourceLocation(source, line=line),
                         hint="write e.g. 2026-01-05T06:00:10") from None
    return stamp


def read_temperature_log(path: str | Path, *, require_timestamp: bool = True) -> TemperatureLog:
    """Read a temperature log CSV.

    Parameters
    ----------
    path : str or Path
    require_timestamp : bool
        Without a ``timestamp`` column, raise (default) or number the samples.

    Raises
    ------
    ParseError
        Unreadable file, no data, missing timestamp column, a bad timestamp or a
        non-numeric cell in a numeric column — with the file and line.
    """
    source = str(path)
    try:
        with open(path, encoding="utf-8-sig", newline="") as stream:
            rows = list(csv.reader(stream))
    except OSError as exc:
        raise ParseError(f"cannot read: {exc.strerror}", location=SourceLocation(source)) from None
    except UnicodeDecodeError:
        raise ParseError("not UTF-8 text", location=SourceLocation(source)) from None
    if not rows:
        raise ParseError("empty file", location=SourceLocation(source))
    header = [h.strip() for h in rows[0]]
    body = [(i + 2, r) for i, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    if not body:
        raise ParseError("no data rows", location=SourceLocation(source, line=2))
    lower = [h.lower() for h in header]
    t_idx = lower.index(TIMESTAMP) if TIMESTAMP in lower else None
    if t_idx is None and require_timestamp:
        raise ParseError("no 'timestamp' column", location=SourceLocation(source, line=1),
                         hint="a temperature log needs timestamp, one column per sensor and the error column")
    for line, row in body:
        if len(row) > len(header):
            raise ParseError(f"{len(row)} cells but {len(header)} columns in the header",
                             location=SourceLocation(source, line=line))
    lines = np.array([line for line, _ in body], dtype=np.int64)
    columns: dict[str, Array] = {}
    for j, name in enumerate(header):
        if j == t_idx or not name:
            continue
        cells = [(row[j].strip() if j < len(row) else "") for _, row in body]
        values = np.full(len(cells), np.nan)
        bad: list[int] = []
        for i, cell in enumerate(cells):
            if not cell:
                continue
            try:
                values[i] = float(cell)
            except ValueError:
                bad.append(i)
        if bad and len(bad) == sum(1 for c in cells if c):
            continue  # a text column: kept out of the numeric table, never an error
        if bad:
            i = bad[0]
            raise ParseError(f"non-numeric value {cells[i]!r} in column {name!r}",
                             location=SourceLocation(source, line=int(lines[i])))
        if np.isinf(values).any():
            i = int(np.flatnonzero(np.isinf(values))[0])
            raise ParseError(f"infinite value in column {name!r}", location=SourceLocation(source, line=int(lines[i])))
        columns[name] = values
    seconds = None
    stamps: list[str] = []
    if t_idx is not None:
        stamps = [row[t_idx].strip() if t_idx < len(row) else "" for _, row in body]
        times = [_parse_time(s, source, int(line)) for s, line in zip(stamps, lines)]
        try:
            seconds = np.array([(t - times[0]).total_seconds() for t in times])
        except TypeError:
            raise ParseError("timestamps mix time zones and local times", location=SourceLocation(source, line=2)) from None
        back = np.flatnonzero(np.diff(seconds) <= 0)
        if back.size:
            raise ParseError("timestamp not after the previous one", location=SourceLocation(source, line=int(lines[back[0] + 1])),
                             hint="sort the log by time and remove repeated samples")
        if seconds.size > 2:
            steps = np.diff(seconds)
            if np.max(np.abs(steps - np.median(steps))) > 0.05 * np.median(steps):
                warnings.warn(f"{source}: sampling interval varies (median {np.median(steps):g} s); "
                              "grey and lumped-mass models assume equal steps", ParseWarning, stacklevel=2)
    return TemperatureLog(source, columns, seconds, stamps, lines)


@dataclass(frozen=True)
class Selection:
    """Which columns of a log play which role."""

    inputs: tuple[str, ...]
    target: str | None
    ambient: str | None = None
    speed: str | None = None


def select_columns(log: TemperatureLog, *, target: str | None, inputs: Sequence[str] | None = None,
                   ambient: str | None = None, speed: str | None = None, need_ambient: bool = False) -> Selection:
    """Resolve the roles of the columns (``cli-json.md``, ``thermal evaluate``).

    Temperature inputs are every numeric column but the target, the speed and the
    ambient one unless ``inputs`` names them.  The speed column defaults to
    ``spindle_speed`` and the ambient one to ``ambient`` when present.
    """
    loc = SourceLocation(log.source, line=1)
    if target is not None and target not in log.columns:
        raise ParseError(f"target column {target!r} not found or not numeric", location=loc,
                         hint=f"numeric columns: {', '.join(log.columns)}")
    speed = speed or (SPEED if SPEED in log.columns else None)
    if speed is not None and speed not in log.columns:
        raise ParseError(f"speed column {speed!r} not found", location=loc)
    if ambient is None and need_ambient:
        ambient = AMBIENT if AMBIENT in log.columns else None
        if ambient is None:
            raise ParseError("the kalman model needs an ambient temperature column", location=loc,
                             hint="name it 'ambient' or pass --ambient COL")
    if ambient is not None and ambient not in log.columns:
        raise ParseError(f"ambient column {ambient!r} not found", location=loc)
    if inputs:
        missing = [c for c in inputs if c not in log.columns]
        if missing:
            raise ParseError(f"input column {missing[0]!r} not found or not numeric", location=loc,
                             hint=f"numeric columns: {', '.join(log.columns)}")
        chosen = tuple(inputs)
    else:
        skip = {target, speed}
        if need_ambient or ambient is not None:
            skip.add(ambient)
        chosen = tuple(c for c in log.columns if c not in skip)
    if not chosen:
        raise ParseError("no temperature columns", location=loc)
    return Selection(chosen, target, ambient, speed)
