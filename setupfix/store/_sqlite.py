"""The embedded history store: one SQLite file (stdlib ``sqlite3``), WAL mode.

WAL lets readers in other processes read the last committed state while one
process writes; writers wait up to :data:`BUSY_TIMEOUT_S` for each other.  The
connection runs in autocommit mode and :meth:`SQLiteStore.transaction` issues
``BEGIN IMMEDIATE`` … ``COMMIT`` itself, so one import is one transaction and a kill
at any point leaves the last committed state (SQLite's journal rolls back the rest).
One :class:`SQLiteStore` belongs to one thread; other threads open their own.

Every public method turns a database failure into one :class:`StoreError` naming the
file and what is wrong with it (:func:`_failure`: damaged, read-only, locked beyond
:data:`BUSY_TIMEOUT_S`, full, I/O error); nothing reaches the caller as a bare
``sqlite3`` or pandas error.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
import sqlite3
from collections.abc import Callable, Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

import pandas as pd

from setupfix.errors import SourceLocation, StoreError
from setupfix.model import CANONICAL_COLUMNS
from setupfix.store import (ALREADY_PROCESSED, CORRECTION_COLUMNS, HELD_ELSEWHERE, Claimant, Recommendation,
                            ReportRecord, Store)
from setupfix.store._schema import migrate, rollback

__all__ = ["SQLiteStore", "BUSY_TIMEOUT_S"]

#: How long a writer waits for another process's write transaction, seconds.
BUSY_TIMEOUT_S = 30.0

_TEXT = frozenset(c for c in CANONICAL_COLUMNS if c not in
                  ("nominal", "actual", "deviation", "lower", "upper", "x", "y", "z"))


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


#: (SQLite result code prefix, what is wrong, hint) in the order they are tried.
_FAILURES: tuple[tuple[tuple[str, ...], str, str | None], ...] = (
    (("SQLITE_BUSY", "SQLITE_LOCKED"), "the history store is locked by another process (waited {timeout:g} s)",
     "another setupfix or a database tool is writing it: run again when it is done"),
    (("SQLITE_READONLY",), "the history store cannot be written (read-only file, folder or file system)",
     "SQLite writes the file and a -wal and -shm file beside it: allow writing both"),
    (("SQLITE_FULL",), "the history store cannot grow: its disk is full", "free space and run again"),
    (("SQLITE_IOERR",), "the history store cannot be read or written (disk I/O error)",
     "is the disk full, a file size limit (ulimit -f) reached, or the disk failing?"),
    (("SQLITE_CORRUPT", "SQLITE_NOTADB"), "the history store is damaged (not a readable SQLite database)",
     "restore it from a backup, or give another --db/--store"),
    (("SQLITE_CANTOPEN", "SQLITE_PERM", "SQLITE_AUTH"), "the history store cannot be opened or created",
     "is the path a file, and may this user write its folder?"),
)


def _failure(exc: BaseException, path: str) -> StoreError:
    """A database failure as one :class:`StoreError` naming the store and what is wrong with it."""
    cause = exc.__cause__ if isinstance(exc.__cause__, sqlite3.Error) else exc  # pandas wraps sqlite's errors
    code = str(getattr(cause, "sqlite_errorname", "") or "")
    text = str(cause)
    for prefixes, message, hint in _FAILURES:
        if code.startswith(prefixes):
            return StoreError(message.format(timeout=BUSY_TIMEOUT_S), location=SourceLocation(path), hint=hint)
    return StoreError(f"history store: {text}", location=SourceLocation(path))


_P = ParamSpec("_P")
_R = TypeVar("_R")
#: What a database failure looks like to a method (pandas' read_sql_query wraps sqlite3's errors).
_DB_ERRORS = (sqlite3.Error, pd.errors.DatabaseError)


def _guarded(method: Callable[_P, _R]) -> Callable[_P, _R]:
    """A store method whose database failures are :class:`StoreError` naming the store."""

    @functools.wraps(method)
    def run(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        try:
            return method(*args, **kwargs)
        except _DB_ERRORS as exc:
            raise _failure(exc, args[0].location) from None  # type: ignore[attr-defined]  # args[0] is self

    return run


def _age_s(at: str | None) -> float:
    """Seconds since the ISO time ``at`` (infinite when it cannot be read)."""
    try:
        then = datetime.fromisoformat(str(at))
    except ValueError:
        return math.inf
    if then.tzinfo is None:
        then = then.replace(tzinfo=UTC)
    return (datetime.now(UTC) - then).total_seconds()


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
        if path != ":memory:" and Path(path).exists() and not Path(path).is_file():
            raise StoreError("the history store is not a file", location=self._where, hint="give a file (--db)")
        db: sqlite3.Connection | None = None
        try:
            db = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
            db.execute("PRAGMA journal_mode = WAL")
            db.execute("PRAGMA synchronous = FULL")
            db.execute("PRAGMA foreign_keys = ON")
            migrate(db, path)
        except BaseException as exc:
            if db is not None:
                db.close()
            if isinstance(exc, sqlite3.Error):
                raise _failure(exc, path) from None
            raise
        self.db = db

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
        except sqlite3.Error as exc:
            raise _failure(exc, self.location) from None
        self._depth = 1
        try:
            yield
            self.db.execute("COMMIT")
        except sqlite3.Error as exc:  # the COMMIT itself (a full disk, an I/O error)
            rollback(self.db)
            raise _failure(exc, self.location) from None
        except BaseException:
            rollback(self.db)
            raise
        finally:
            self._depth = 0

    def close(self) -> None:
        with contextlib.suppress(sqlite3.Error):
            self.db.close()

    def __enter__(self) -> SQLiteStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- reports and their rows --------------------------------------------------------------
    @_guarded
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

    @_guarded
    def report(self, sha256: str) -> ReportRecord | None:
        found = self._reports("WHERE r.sha256 = ?", (sha256,))
        return found[0] if found else None

    @_guarded
    def reports(self) -> list[ReportRecord]:
        return self._reports("", ())

    def _reports(self, where: str, args: Sequence[Any]) -> list[ReportRecord]:
        sql = ("SELECT r.sha256, r.name, r.format, r.size, (SELECT count(*) FROM measurement m "
               f"WHERE m.report_id = r.id), r.imported_at FROM report r {where} ORDER BY r.id")
        return [ReportRecord(*row) for row in self.db.execute(sql, args)]

    @_guarded
    def measurements(self, sha256: str | None = None) -> pd.DataFrame:
        cols = ", ".join(f"m.{c}" for c in CANONICAL_COLUMNS)
        where, args = ("WHERE r.sha256 = ?", (sha256,)) if sha256 else ("", ())
        frame = pd.read_sql_query(f"SELECT {cols}, m.reference, r.sha256 AS report_sha256 FROM measurement m "
                                  f"JOIN report r ON r.id = m.report_id {where} ORDER BY r.id, m.row",
                                  self.db, params=args)
        frame["reference"] = frame["reference"].astype(bool)
        return frame

    # -- logs: corrections and temperatures ---------------------------------------------------
    @_guarded
    def add_corrections(self, log: pd.DataFrame) -> int:
        frame = log.reindex(columns=list(CORRECTION_COLUMNS))
        rows = [(str(t), str(r), _cell(d, False), str(e or "correction"))
                for t, r, d, e in frame.itertuples(index=False)]
        return self._merge("correction", CORRECTION_COLUMNS, ("timestamp", "register", "event"), rows)

    @_guarded
    def corrections(self, event: str | None = None) -> pd.DataFrame:
        where, args = ("WHERE event = ?", (event,)) if event else ("", ())
        return pd.read_sql_query(f"SELECT timestamp, register, delta, event FROM correction {where} "
                                 "ORDER BY timestamp, rowid", self.db, params=args)

    @_guarded
    def add_temperatures(self, log: pd.DataFrame) -> int:
        if "timestamp" not in log:
            raise StoreError("a temperature log needs a timestamp column", location=self._where)
        long = log.melt(id_vars=["timestamp"], var_name="channel", value_name="value").dropna(subset=["value"])
        rows = [(str(t), str(c), float(v)) for t, c, v in long.itertuples(index=False)]
        return self._merge("temperature", ("timestamp", "channel", "value"), ("timestamp", "channel"), rows)

    @_guarded
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
    @_guarded
    def add_recommendation(self, rec: Recommendation) -> int:
        with self.transaction():
            cur = self.db.execute(
                "INSERT INTO recommendation (created_at, optimizer, inputs, result) VALUES (?,?,?,?)",
                (rec.created_at or _now(), rec.optimizer, json.dumps(rec.inputs, sort_keys=True),
                 json.dumps(rec.result, sort_keys=True)))
        return int(cur.lastrowid or 0)

    @_guarded
    def recommendations(self) -> list[Recommendation]:
        rows = self.db.execute("SELECT optimizer, inputs, result, created_at FROM recommendation ORDER BY id")
        return [Recommendation(o, json.loads(i), json.loads(r), c) for o, i, r, c in rows]

    @_guarded
    def verify(self) -> None:
        problems = [str(r[0]) for r in self.db.execute("PRAGMA quick_check")]
        if problems != ["ok"]:
            raise StoreError("the history store is damaged (not a readable SQLite database)",
                             location=self._where, hint="restore it from a backup, or give another --db/--store")

    # -- batch claims --------------------------------------------------------------------------
    @_guarded
    def claim_reports(self, keys: Sequence[str], claimant: Claimant, *, again: bool = False) -> dict[str, str]:
        refused: dict[str, str] = {}
        with self.transaction():
            for key in dict.fromkeys(keys):
                row = self.db.execute("SELECT done, owner, host, pid, started, claimed_at FROM batch_claim "
                                      "WHERE report_sha256 = ?", (key,)).fetchone()
                if row is not None:
                    done, owner, host, pid, started, at = row
                    if owner is not None and owner != claimant.token:
                        holder = Claimant(owner, str(host or ""), int(pid or 0), str(started or ""))
                        if not holder.gone(_age_s(at)):
                            refused[key] = f"{HELD_ELSEWHERE} ({holder}, since {at}): left to it"
                            continue
                    if done and not again and owner != claimant.token:
                        refused[key] = ALREADY_PROCESSED
                        continue
                self.db.execute(
                    "INSERT INTO batch_claim (report_sha256, done, owner, host, pid, started, claimed_at) "
                    "VALUES (?, 0, ?, ?, ?, ?, ?) ON CONFLICT (report_sha256) DO UPDATE SET owner = excluded.owner, "
                    "host = excluded.host, pid = excluded.pid, started = excluded.started, "
                    "claimed_at = excluded.claimed_at",
                    (key, claimant.token, claimant.host, claimant.pid, claimant.started, _now()))
        return refused

    @_guarded
    def finish_claims(self, keys: Sequence[str], claimant: Claimant) -> None:
        with self.transaction():
            self.db.executemany("UPDATE batch_claim SET done = 1, owner = NULL, host = NULL, pid = NULL, "
                                "started = NULL, claimed_at = NULL WHERE report_sha256 = ? AND owner = ?",
                                [(k, claimant.token) for k in dict.fromkeys(keys)])

    @_guarded
    def release_claims(self, claimant: Claimant) -> None:
        with self.transaction():
            self.db.execute("UPDATE batch_claim SET owner = NULL, host = NULL, pid = NULL, started = NULL, "
                            "claimed_at = NULL WHERE owner = ?", (claimant.token,))
            self.db.execute("DELETE FROM batch_claim WHERE owner IS NULL AND done = 0")
