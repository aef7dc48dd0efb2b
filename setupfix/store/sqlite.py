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
import sqlite3
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from setupfix.core.errors import SourceLocation, StoreError
from setupfix.store.claims import ClaimingStore
from setupfix.store.schema import migrate, rollback
from setupfix.store.sql import guarded

__all__ = ["SQLiteStore", "BUSY_TIMEOUT_S"]

#: How long a writer waits for another process's write transaction, seconds.
BUSY_TIMEOUT_S = 30.0

#: (SQLite result code prefix, what is wrong, hint) in the order they are tried.
_FAILURES: tuple[tuple[tuple[str, ...], str, str | None], ...] = (
    (
        ("SQLITE_BUSY", "SQLITE_LOCKED"),
        "the history store is locked by another process (waited {timeout:g} s)",
        "another setupfix or a database tool is writing it: run again when it is done",
    ),
    (
        ("SQLITE_READONLY",),
        "the history store cannot be written (read-only file, folder or file system)",
        "SQLite writes the file and a -wal and -shm file beside it: allow writing both",
    ),
    (("SQLITE_FULL",), "the history store cannot grow: its disk is full", "free space and run again"),
    (
        ("SQLITE_IOERR",),
        "the history store cannot be read or written (disk I/O error)",
        "is the disk full, a file size limit (ulimit -f) reached, or the disk failing?",
    ),
    (
        ("SQLITE_CORRUPT", "SQLITE_NOTADB"),
        "the history store is damaged (not a readable SQLite database)",
        "restore it from a backup, or give another --db/--store",
    ),
    (
        ("SQLITE_CANTOPEN", "SQLITE_PERM", "SQLITE_AUTH"),
        "the history store cannot be opened or created",
        "is the path a file, and may this user write its folder?",
    ),
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


def _connect(path: str) -> sqlite3.Connection:
    """Open, switch to WAL and migrate ``path``; retried while another process creates it.

    SQLite answers ``SQLITE_BUSY`` at once, without its busy handler, to a connection
    that reads a WAL file another process is still setting up (the journal-mode switch
    of a new store, the recovery of a WAL index).  Every step here is idempotent, so
    the whole open is tried again with a growing pause until :data:`BUSY_TIMEOUT_S`.
    """
    deadline = time.monotonic() + BUSY_TIMEOUT_S
    pause = 0.01
    while True:
        db: sqlite3.Connection | None = None
        try:
            db = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
            db.execute("PRAGMA journal_mode = WAL")
            db.execute("PRAGMA synchronous = FULL")
            db.execute("PRAGMA foreign_keys = ON")
            migrate(db, path)
            return db
        except BaseException as exc:
            if db is not None:
                db.close()
            if not isinstance(exc, sqlite3.Error):
                raise
            busy = str(getattr(exc, "sqlite_errorname", "")).startswith(("SQLITE_BUSY", "SQLITE_LOCKED"))
            if not busy or time.monotonic() + pause > deadline:
                raise _failure(exc, path) from None
        time.sleep(pause)
        pause = min(2 * pause, 0.5)


class SQLiteStore(ClaimingStore):
    """:class:`~setupfix.store.Store` in one SQLite file (created and migrated on open)."""

    errors = (sqlite3.Error, pd.errors.DatabaseError)

    def __init__(self, path: str, *, machine: str, operator: str) -> None:
        self.location, self.machine, self.operator = path, machine, operator
        self._where = SourceLocation(path)
        self._depth = 0
        if path != ":memory:" and not Path(path).parent.is_dir():
            raise StoreError(f"folder {str(Path(path).parent)!r} does not exist", location=self._where)
        if path != ":memory:" and Path(path).exists() and not Path(path).is_file():
            raise StoreError("the history store is not a file", location=self._where, hint="give a file (--db)")
        self.db = _connect(path)

    def _execute(self, sql: str, args: Sequence[Any] = ()) -> sqlite3.Cursor:
        return self.db.execute(sql, args)

    def _executemany(self, sql: str, rows: Iterable[Sequence[Any]]) -> None:
        self.db.executemany(sql, rows)

    def _begin(self) -> None:
        self.db.execute("BEGIN IMMEDIATE")

    def _commit(self) -> None:
        self.db.execute("COMMIT")

    def _rollback(self) -> None:
        rollback(self.db)

    def _failure(self, exc: BaseException) -> StoreError:
        return _failure(exc, self.location)

    def _as_text(self, column: str) -> str:
        return f"quote({column})"

    def close(self) -> None:
        with contextlib.suppress(sqlite3.Error):
            self.db.close()

    @guarded
    def verify(self) -> None:
        problems = [str(r[0]) for r in self.db.execute("PRAGMA quick_check")]
        if problems != ["ok"]:
            raise StoreError(
                "the history store is damaged (not a readable SQLite database)",
                location=self._where,
                hint="restore it from a backup, or give another --db/--store",
            )
