"""The corrections log (``measurements.md``, "Corrections log"): the one reader and the one model check.

Every door that takes a corrections log — ``history import``, ``diagnose --corrections``,
a log found beside the reports, the log kept in a history store — reads it here, so a
header is accepted or refused alike and a bad row is named at the same line:

* :func:`read_corrections_log` — file → :class:`CorrectionsLog` (typed rows, each with
  its file and line).  The header is matched without regard to case or surrounding
  blanks (``Timestamp,Register,Delta``); ``timestamp``, ``register`` and ``delta`` are
  required, ``event`` optional, other columns ignored.  Refused, naming file and line:
  text that is not UTF-8, a column named twice, a row with more cells than the header
  (``…,0,05`` — a decimal comma — would otherwise lose its second half), a bad
  timestamp, an empty register, a delta that is not a plain decimal number, a
  correction without delta, a tool change with one, an unknown event, a row given
  twice (same time, register and event: a store keeps one, a sum would count two).
* :func:`log_from_frame` — the rows of a history store, through the same row checks
  (named by the store and the row).
* :func:`check_corrections` — a log against a process model: every register known to
  the model, tool changes only of tools, no register changed twice at one time (by its
  ID and its register name) → :class:`RegisterLog` (arrays for the engine).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime

import numpy as np
import numpy.typing as npt
import pandas as pd

from parsers import numbers
from parsers.source import csv_records, read_bytes
from parsers.timestamps import parse_timestamp, to_index, utc_naive
from setupfix.core.errors import MatchError, ParseError, SourceLocation
from setupfix.model import ProcessModel

__all__ = [
    "CorrectionRow",
    "CorrectionsLog",
    "RegisterLog",
    "read_corrections_log",
    "log_from_frame",
    "check_corrections",
    "EVENTS",
    "COLUMNS",
    "REQUIRED",
]

#: Kinds of rows: a change of a register, or a tool change (the tool's wear restarts).
EVENTS: tuple[str, ...] = ("correction", "tool_change")
#: Columns of the log, in the order the store and ``history export`` keep them.
COLUMNS: tuple[str, ...] = ("timestamp", "register", "delta", "event")
#: Columns a log must have.
REQUIRED: tuple[str, ...] = ("timestamp", "register", "delta")


@dataclass(frozen=True, slots=True)
class CorrectionRow:
    """One row of a corrections log.

    Attributes
    ----------
    moment : datetime
        When the change was made (as written; with its offset when one is written).
    register : str
        The register as written (a model register ID or its ``register`` name).
    delta : float
        The change in the model unit; NaN for a tool change.
    event : str
        ``correction`` or ``tool_change``.
    where : SourceLocation
        File and line (or store and row) of the row.
    """

    moment: datetime
    register: str
    delta: float
    event: str
    where: SourceLocation

    @property
    def timestamp(self) -> str:
        """The timestamp in ISO normal form."""
        return self.moment.isoformat()


@dataclass(frozen=True, slots=True)
class CorrectionsLog:
    """The rows of one corrections log, in file order."""

    source: str
    rows: tuple[CorrectionRow, ...] = ()

    def frame(self) -> pd.DataFrame:
        """The rows as the canonical table (:data:`COLUMNS`; timestamps in ISO normal form)."""
        return pd.DataFrame([(r.timestamp, r.register, r.delta, r.event) for r in self.rows], columns=list(COLUMNS))


@dataclass(frozen=True)
class RegisterLog:
    """A corrections log checked against a model, as arrays for the engine.

    Attributes
    ----------
    times : DatetimeIndex, shape (n,)
        When each row took effect (naive; a time with an offset converted to UTC).
    registers : ndarray of intp, shape (n,)
        Index of each row's register in ``model.register_ids``.
    deltas : ndarray of float, shape (n,)
        The change, model unit (0 for a tool change).
    events : tuple of str, length n
    """

    times: pd.DatetimeIndex
    registers: npt.NDArray[np.intp]
    deltas: npt.NDArray[np.float64]
    events: tuple[str, ...]


def _row(cells: Mapping[str, str], where: SourceLocation) -> CorrectionRow | None:
    """The checks every row goes through (file or store); None for a blank row."""
    if not any(str(c).strip() for c in cells.values()):
        return None
    event = (cells.get("event") or "").strip().casefold() or "correction"
    if event not in EVENTS:
        raise ParseError(f"unknown event {event!r} (expected {' or '.join(EVENTS)})", location=where)
    moment = parse_timestamp(cells.get("timestamp", ""), where)
    register = (cells.get("register") or "").strip()
    if not register:
        raise ParseError("empty register", location=where)
    delta = numbers.parse_number(cells.get("delta") or "", location=where, what="column 'delta'", allow_empty=True)
    if event == "correction" and math.isnan(delta):
        raise ParseError("a correction needs a delta", location=where)
    if event == "tool_change" and not (math.isnan(delta) or delta == 0):
        raise ParseError(
            f"a tool change carries no delta (found {delta:g})",
            location=where,
            hint="leave delta empty, and give a correction on a row of its own",
        )
    return CorrectionRow(moment, register, math.nan if event == "tool_change" else delta, event, where)


def _place(where: SourceLocation) -> str:
    """A row's place within its log: ``line 3`` (file) or ``row 3`` (store)."""
    return f"line {where.line}" if where.line is not None else where.element or str(where)


def _once(rows: list[CorrectionRow], source: str) -> CorrectionsLog:
    """The log, refusing a row given twice (same time, register and event).

    A history store keeps one row per (timestamp, register, event); a file with two would
    be read as two changes by one door and as one by another, so it is refused.
    """
    seen: dict[tuple[datetime, str, str], CorrectionRow] = {}
    for row in rows:
        key = (utc_naive(row.moment), row.register, row.event)
        if key in seen:
            raise ParseError(
                f"{row.register} {row.event.replace('_', ' ')} at {row.timestamp} given twice "
                f"(also at {_place(seen[key].where)})",
                location=row.where,
                hint="give one row with the total change",
            )
        seen[key] = row
    return CorrectionsLog(source, tuple(rows))


def _header(cells: list[str], where: SourceLocation) -> list[str]:
    header = [c.strip().casefold() for c in cells]
    seen: dict[str, int] = {}
    for j, name in enumerate(header):
        if name and name in seen:
            raise ParseError(f"column {name!r} appears twice (columns {seen[name] + 1} and {j + 1})", location=where)
        seen[name] = j
    missing = [c for c in REQUIRED if c not in seen]
    if missing:
        raise ParseError(
            f"not a corrections log: missing column(s) {', '.join(missing)}",
            location=where,
            hint=f"the header names {', '.join(COLUMNS)} (event optional)",
        )
    return header


def read_corrections_log(path: str | os.PathLike[str]) -> CorrectionsLog:
    """Read a corrections log (CSV, UTF-8, one header row).

    Raises
    ------
    ParseError
        Naming the file and line; see the module's list.
    """
    name = str(path)
    data = read_bytes(name)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ParseError(
            "not UTF-8 text",
            location=SourceLocation(name, line=data[: exc.start].count(b"\n") + 1),
            hint="save the log as UTF-8 (measurements.md)",
        ) from None
    records = csv_records(text, name)
    first = next(records, None)
    if first is None:
        raise ParseError("empty file: not a corrections log", location=SourceLocation(name, line=1))
    header = _header(first[1], SourceLocation(name, line=first[0]))
    rows = []
    for line, cells in records:
        where = SourceLocation(name, line=line)
        if len(cells) > len(header) and any(c.strip() for c in cells[len(header) :]):
            raise ParseError(
                f"{len(cells)} cells but {len(header)} columns in the header",
                location=where,
                hint="a decimal comma splits a number in two: write 0.05, not 0,05",
            )
        row = _row(dict(zip(header, cells, strict=False)), where)  # a short row: its missing cells are empty
        if row is not None:
            rows.append(row)
    return _once(rows, name)


def log_from_frame(frame: pd.DataFrame, source: str) -> CorrectionsLog:
    """A log kept as a table (a history store's rows) through the same row checks.

    Rows are named ``source`` and ``row N`` (1-based, in the table's order).
    """
    table = frame.astype(object).where(frame.notna(), "")
    table.columns = [str(c).strip().casefold() for c in table.columns]
    _header(list(table.columns), SourceLocation(source))
    rows = []
    for i, rec in enumerate(table.to_dict("records"), start=1):
        row = _row({str(k): str(v) for k, v in rec.items()}, SourceLocation(source, element=f"row {i}"))
        if row is not None:
            rows.append(row)
    return _once(rows, source)


def check_corrections(log: CorrectionsLog, model: ProcessModel) -> RegisterLog:
    """Tie every row to a register of ``model``.

    Raises
    ------
    MatchError
        At the row: a register the model does not know (by ID or register name), or
        a tool change of a register that is not a tool.
    """
    ids = model.register_ids
    regs: list[int] = []
    seen: dict[tuple[datetime, str, str], CorrectionRow] = {}
    for row in log.rows:
        try:
            reg = model.register(row.register)
        except KeyError:
            raise MatchError(
                f"unknown register {row.register!r} (model registers: {', '.join(ids)})", location=row.where
            ) from None
        if row.event == "tool_change" and reg.kind != "tool":
            raise MatchError(f"tool change of {reg.id}, which is not a tool", location=row.where)
        key = (utc_naive(row.moment), reg.id, row.event)
        if key in seen:  # the same register by its ID and its register name
            raise MatchError(
                f"{reg.id} ({reg.register}) {row.event.replace('_', ' ')} at {row.timestamp} given "
                f"twice (also at {_place(seen[key].where)})",
                location=row.where,
                hint="give one row with the total change",
            )
        seen[key] = row
        regs.append(ids.index(reg.id))
    deltas = np.array([0.0 if r.event == "tool_change" else r.delta for r in log.rows], dtype=float)
    return RegisterLog(
        to_index([r.moment for r in log.rows]), np.array(regs, dtype=np.intp), deltas, tuple(r.event for r in log.rows)
    )
