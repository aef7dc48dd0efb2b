"""The embedded history store: one SQLite file (stdlib ``sqlite3``), WAL mode.

WAL lets readers in other processes read the last committed state while one
process writes; writers wait up to :data:`BUSY_TIMEOUT_S` for each other.  The
connection runs in autocommit mode and :meth:`SQLiteStore.transaction` issues
``BEGIN IMMEDIATE`` … ``COMMIT`` itself, so one import is one transaction and a kill
at any point leaves the last committed state (SQLite's journal rolls back the rest).
One :class:`SQLiteStore` belongs to one thread; other threads open their own.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import sqlite3
from collections.abc import Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from setupfix.errors import SourceLocation, StoreError
from setupfix.model import CANONICAL_COLUMNS
from setupfix.store import CORRECTION_COLUMNS, Recommendation, ReportRecord, Store
from setupfix.store._schema import migrate

__all__ = ["SQLiteStore", "BUSY_TIMEOUT_S"]

#: How long a writer waits for another process's write transaction, seconds.
BUSY_TIMEOUT_S = 30.0

_TEXT = frozenset(c for c in CANONICAL_COLUMNS if c not in
                  ("nominal", "actual", "deviation", "lower", "upper", "x", "y", "z"))


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _cell(value: Any, text: bool) -> Any:
    """A DataFrame cell as an SQLite value: NaN/None/"" → NULL, numbers as float, text as str."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if text:
        return str(value) if str(value) != "" else None
    return float(value)


class SQLiteStore(Store):
    """:class:`~setupfix.store.Store` in one SQLite file (created and migrated on open)."""

    def __init__(self, path: str) -> None:
        self.location = path
        self._where = SourceLocation(path)
        self._depth = 0
        if path != ":memory:" and not Path(path).parent.is_dir():
            raise StoreError(f"folder {str(Path(path).parent)!r} does not exist", location=self._where)
        try:
            self.db = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
            self.db.execute("PRAGMA journal_mode = WAL")
            self.db.execute("PRAGMA synchronous = FULL")
            self.db.execute("PRAGMA foreign_keys = ON")
            migrate(self.db, path)
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"cannot open the history store: {exc}", location=self._where,
                             hint="is it a setupfix store (--db)?") from None

    # -- transactions ------------------------------------------------------------------------
    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        if self._depth:
            self._depth += 1
            try:
                yield
            finally:
                self._depth -= 1
            return
        try:
            self.db.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as exc:
            raise StoreError(f"cannot write the history store: {exc}", location=self._where) from None
        self._depth = 1
        try:
            yield
            self.db.execute("COMMIT")
        except BaseException:
            self.db.execute("ROLLBACK")
            raise
        finally:
            self._depth = 0

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> SQLiteStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- reports and their rows --------------------------------------------------------------
    def add_report(self, data: bytes, name: str, format: str, table: pd.DataFrame) -> tuple[str, bool]:
        sha = hashlib.sha256(data).hexdigest()
        with self.transaction():
            if self.report(sha) is not None:
                return sha, False
            cur = self.db.execute("INSERT INTO report (sha256, name, format, size, imported_at) VALUES (?,?,?,?,?)",
                                  (sha, name, format, len(data), _now()))
            report_id = cur.lastrowid
            cols = list(CANONICAL_COLUMNS)
            frame = table.reindex(columns=[*cols, "reference"])
            flags = [int(str(v).strip().lower() in ("true", "1", "1.0")) for v in frame["reference"]]
            rows = [(report_id, i, *(_cell(v, c in _TEXT) for c, v in zip(cols, values, strict=True)), flag)
                    for i, (values, flag) in enumerate(zip(frame[cols].itertuples(index=False), flags, strict=True))]
            marks = ",".join("?" * (len(cols) + 3))
            self.db.executemany(f"INSERT INTO measurement (report_id, row, {', '.join(cols)}, reference) "
                                f"VALUES ({marks})", rows)
        return sha, True

    def report(self, sha256: str) -> ReportRecord | None:
        found = self._reports("WHERE r.sha256 = ?", (sha256,))
        return found[0] if found else None

    def reports(self) -> list[ReportRecord]:
        return self._reports("", ())

    def _reports(self, where: str, args: Sequence[Any]) -> list[ReportRecord]:
        sql = ("SELECT r.sha256, r.name, r.format, r.size, (SELECT count(*) FROM measurement m "
               f"WHERE m.report_id = r.id), r.imported_at FROM report r {where} ORDER BY r.id")
        return [ReportRecord(*row) for row in self.db.execute(sql, args)]

    def measurements(self, sha256: str | None = None) -> pd.DataFrame:
        cols = ", ".join(f"m.{c}" for c in CANONICAL_COLUMNS)
        where, args = ("WHERE r.sha256 = ?", (sha256,)) if sha256 else ("", ())
        frame = pd.read_sql_query(f"SELECT {cols}, m.reference, r.sha256 AS report_sha256 FROM measurement m "
                                  f"JOIN report r ON r.id = m.report_id {where} ORDER BY r.id, m.row",
                                  self.db, params=args)
        frame["reference"] = frame["reference"].astype(bool)
        return frame

    # -- logs: corrections and temperatures ---------------------------------------------------
    def add_corrections(self, log: pd.DataFrame) -> int:
        frame = log.reindex(columns=list(CORRECTION_COLUMNS))
        rows = [(str(t), str(r), _cell(d, False), str(e or "correction"))
                for t, r, d, e in frame.itertuples(index=False)]
        return self._merge("correction", CORRECTION_COLUMNS, ("timestamp", "register", "event"), rows)

    def corrections(self, event: str | None = None) -> pd.DataFrame:
        where, args = ("WHERE event = ?", (event,)) if event else ("", ())
        return pd.read_sql_query(f"SELECT timestamp, register, delta, event FROM correction {where} "
                                 "ORDER BY timestamp, rowid", self.db, params=args)

    def add_temperatures(self, log: pd.DataFrame) -> int:
        if "timestamp" not in log:
            raise StoreError("a temperature log needs a timestamp column", location=self._where)
        long = log.melt(id_vars=["timestamp"], var_name="channel", value_name="value").dropna(subset=["value"])
        rows = [(str(t), str(c), float(v)) for t, c, v in long.itertuples(index=False)]
        return self._merge("temperature", ("timestamp", "channel", "value"), ("timestamp", "channel"), rows)

    def temperatures(self) -> pd.DataFrame:
        long = pd.read_sql_query("SELECT timestamp, channel, value FROM temperature ORDER BY timestamp", self.db)
        if long.empty:
            return pd.DataFrame(columns=["timestamp"])
        wide = long.pivot(index="timestamp", columns="channel", values="value").reset_index()
        wide.columns.name = None
        return wide

    def _merge(self, table: str, columns: Sequence[str], keys: Sequence[str], rows: list[tuple[Any, ...]]) -> int:
        """Insert ``rows``; repeats of stored rows change nothing, contradictions are refused."""
        values = [c for c in columns if c not in keys]
        cols, on = ", ".join(columns), " AND ".join(f"i.{k} = t.{k}" for k in keys)
        differ = " OR ".join(f"i.{v} IS NOT t.{v}" for v in values)
        with self.transaction():
            self.db.execute(f"CREATE TEMP TABLE IF NOT EXISTS incoming_{table} AS SELECT {cols} FROM {table} WHERE 0")
            self.db.execute(f"DELETE FROM incoming_{table}")
            self.db.executemany(f"INSERT INTO incoming_{table} VALUES ({','.join('?' * len(columns))})", rows)
            key_cols = ", ".join(keys)
            twice = self.db.execute(
                f"SELECT {key_cols} FROM incoming_{table} GROUP BY {key_cols} HAVING "
                + " OR ".join(f"count(DISTINCT quote({v})) > 1" for v in values) + " LIMIT 1").fetchone()
            clash = twice or self.db.execute(f"SELECT {', '.join(f'i.{k}' for k in keys)} FROM incoming_{table} i "
                                             f"JOIN {table} t ON {on} WHERE {differ} LIMIT 1").fetchone()
            if clash:
                what = ", ".join(f"{k} {v}" for k, v in zip(keys, clash, strict=True))
                raise StoreError(f"{table} at {what} contradicts " + ("itself" if twice else "the stored one"),
                                 location=self._where, hint="a stored row is never changed")
            before = self.db.total_changes
            self.db.execute(f"INSERT OR IGNORE INTO {table} ({cols}) SELECT DISTINCT {cols} FROM incoming_{table}")
            new = self.db.total_changes - before
            self.db.execute(f"DELETE FROM incoming_{table}")
        return new

    # -- recommendations -----------------------------------------------------------------------
    def add_recommendation(self, rec: Recommendation) -> int:
        with self.transaction():
            cur = self.db.execute(
                "INSERT INTO recommendation (created_at, optimizer, inputs, result) VALUES (?,?,?,?)",
                (rec.created_at or _now(), rec.optimizer, json.dumps(rec.inputs, sort_keys=True),
                 json.dumps(rec.result, sort_keys=True)))
        return int(cur.lastrowid or 0)

    def recommendations(self) -> list[Recommendation]:
        rows = self.db.execute("SELECT optimizer, inputs, result, created_at FROM recommendation ORDER BY id")
        return [Recommendation(o, json.loads(i), json.loads(r), c) for o, i, r, c in rows]
