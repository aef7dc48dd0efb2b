"""Use cases of the history store: import files, summarise, export the canonical tables.

Shared by ``setupfix history`` and, later, batch and the TUI.  An import reads and
checks every file first (reports through :mod:`parsers`, the corrections log and the
temperature log through their readers) and then stores everything in one
transaction: a bad file, a contradiction with the store or a kill leaves the store as
it was.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import pandas as pd

import parsers
from parsers import numbers
from parsers._source import read_bytes
from setupfix.errors import ParameterError, ParseError, SourceLocation
from setupfix.model import CANONICAL_COLUMNS
from setupfix.pipeline.writers import write_canonical_csv, write_table_csv
from parsers.temperature import read_temperature_log
from setupfix.store import CORRECTION_COLUMNS, Recommendation, Store

__all__ = ["DEFAULT_DB", "default_db_path", "read_corrections_log", "import_history", "ImportSummary",
           "history_summary", "export_history", "record_recommendations", "EXPORTS", "EVENTS"]

DEFAULT_DB = "setupfix.db"
#: Kinds of corrections-log rows (``measurements.md``).
EVENTS = ("correction", "tool_change")
#: Tables ``history export`` writes.
EXPORTS = ("measurements", "corrections", "temperatures")


def default_db_path(db: str | None, model: str | None = None) -> Path:
    """``--db`` if given, else ``setupfix.db`` beside the model, else in the current folder."""
    if db:
        return Path(db)
    return (Path(model).parent if model else Path(".")) / DEFAULT_DB


def _stamp(text: str, where: SourceLocation) -> str:
    """An ISO 8601 timestamp in normal form (sortable as text)."""
    try:
        return datetime.fromisoformat(text.strip().replace("Z", "+00:00")).isoformat()
    except ValueError:
        raise ParseError(f"timestamp {text.strip()[:40]!r} is not ISO 8601", location=where,
                         hint="write e.g. 2026-01-05T06:00:10") from None


def read_corrections_log(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a corrections log (``measurements.md``): timestamp, register, delta, event.

    Raises
    ------
    ParseError
        A missing column, a bad timestamp, an empty register, a non-numeric delta, a
        correction without delta or an unknown event — with file and line.
    """
    name = str(path)
    try:
        text = read_bytes(name).decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ParseError("not UTF-8 text", location=SourceLocation(name)) from None
    reader = csv.reader(io.StringIO(text))
    header = [h.strip().lower() for h in next(reader, [])]
    missing = [c for c in ("timestamp", "register", "delta") if c not in header]
    if missing:
        raise ParseError(f"not a corrections log: missing column(s) {', '.join(missing)}",
                         location=SourceLocation(name, line=1))
    rows = []
    for record in reader:
        where = SourceLocation(name, line=reader.line_num)
        if not any(c.strip() for c in record):
            continue
        row = dict(zip(header, (c.strip() for c in record)))
        event = row.get("event") or "correction"
        if event not in EVENTS:
            raise ParseError(f"unknown event {event!r} (expected {' or '.join(EVENTS)})", location=where)
        if not row.get("register"):
            raise ParseError("empty register", location=where)
        delta = numbers.parse_number(row.get("delta", ""), location=where, what="column 'delta'", allow_empty=True)
        if event == "correction" and delta != delta:
            raise ParseError("a correction needs a delta", location=where)
        rows.append((_stamp(row["timestamp"], where), row["register"], delta, event))
    return pd.DataFrame(rows, columns=list(CORRECTION_COLUMNS))


def _temperature_frame(path: str | os.PathLike[str]) -> pd.DataFrame:
    log = read_temperature_log(Path(path))
    stamps = [_stamp(t, SourceLocation(str(path), line=int(line)))
              for t, line in zip(log.timestamps, log.lines if log.lines is not None else [])]
    return pd.DataFrame({"timestamp": stamps, **log.columns})


@dataclass
class ImportSummary:
    """What one import stored: new reports, reports already there, new log rows."""

    new_reports: list[str] = field(default_factory=list)
    known_reports: list[str] = field(default_factory=list)
    corrections: int = 0
    temperatures: int = 0
    notes: list[str] = field(default_factory=list)


def import_history(store: Store, reports: Sequence[str | os.PathLike[str]] = (),
                   corrections: Sequence[str | os.PathLike[str]] = (),
                   temperatures: Sequence[str | os.PathLike[str]] = (), *, format: str | None = None,
                   unit: str | None = None, encoding: str | None = None, lenient: bool = False) -> ImportSummary:
    """Read every file, then store all of it in one transaction.

    Raises
    ------
    SetupfixError
        The first file that cannot be read (nothing is stored), or a log row that
        contradicts the store (nothing is stored).
    """
    read = []
    summary = ImportSummary()
    for path in reports:
        source = parsers.load_source(str(path))  # read once: the bytes hashed are the bytes parsed
        result = parsers.read_report(source, format=format, unit=unit, encoding=encoding, lenient=lenient)
        summary.notes += [str(n) for n in result.notes]
        read.append((source.data, source.name, result.format, result.table))
    logs = [read_corrections_log(p) for p in corrections]
    temps = [_temperature_frame(p) for p in temperatures]
    with store.transaction():
        for data, name, fmt, table in read:
            _, new = store.add_report(data, Path(name).name, fmt, table)
            (summary.new_reports if new else summary.known_reports).append(name)
        for log in logs:
            summary.corrections += store.add_corrections(log)
        for frame in temps:
            summary.temperatures += store.add_temperatures(frame)
    return summary


def history_summary(store: Store) -> dict[str, object]:
    """Reports (name, reader, rows, parts, first and last timestamp), corrections, tool changes, temperatures."""
    rows = store.measurements()
    reports = []
    for rec in store.reports():
        mine = rows[rows["report_sha256"] == rec.sha256]
        stamps = mine["timestamp"].dropna()
        reports.append({"report": rec.name, "sha256": rec.sha256[:12], "format": rec.format, "rows": rec.rows,
                        "parts": int(mine["part"].fillna("").nunique()),
                        "first": str(stamps.min()) if len(stamps) else "",
                        "last": str(stamps.max()) if len(stamps) else "",
                        "imported": rec.imported_at})
    log = store.corrections()
    temps = store.temperatures()
    return {"store": store.location, "reports": reports,
            "corrections": int((log["event"] == "correction").sum()),
            "tool_changes": int((log["event"] == "tool_change").sum()),
            "registers": sorted(log["register"].unique().tolist()),
            "temperature_samples": len(temps), "temperature_channels": [c for c in temps.columns if c != "timestamp"],
            "recommendations": len(store.recommendations())}


def export_history(store: Store, table: str, target: str | os.PathLike[str]) -> int:
    """Write one stored table as its canonical CSV (``-``: standard output); the number of rows."""
    if table == "measurements":
        frame = store.measurements()
        write_canonical_csv(frame[[*CANONICAL_COLUMNS, "reference"]], target)
    elif table == "corrections":
        frame = store.corrections()
        write_table_csv(frame, target)
    elif table == "temperatures":
        frame = store.temperatures()
        write_table_csv(frame, target)
    else:
        raise ParameterError(f"history export: table must be one of {', '.join(EXPORTS)}, got {table!r}")
    return len(frame)


def record_recommendations(store: Store, results: Sequence[Any], *, model: str | os.PathLike[str],
                           report: str | os.PathLike[str], seed: int | None = None) -> list[int]:
    """Store the recommendations of one ``correct`` run (``PartCorrection`` objects), one transaction.

    Inputs kept: the SHA-256 of the model and report files, their names, part and seed;
    the result is the ``correct --json`` object of each part.  Returns the stored ids.
    """
    hashes = {k: hashlib.sha256(read_bytes(str(p))).hexdigest() for k, p in (("model", model), ("report", report))}
    ids = []
    with store.transaction():
        for r in results:
            result = r.to_json()
            inputs = {"model": str(model), "model_sha256": hashes["model"], "report": str(report),
                      "report_sha256": hashes["report"], "part": result.get("part"), "seed": seed}
            ids.append(store.add_recommendation(Recommendation(result["optimizer"], inputs, result)))
    return ids
