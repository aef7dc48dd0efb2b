"""The embedded history store: one SQLite file (stdlib ``sqlite3``), WAL mode.

WAL lets readers in other processes read the last committed state while one
process writes; writers wait up to :data:`BUSY_TIMEOUT_S` for each other.  The
connection runs in autocommit mode and :meth:`SQLiteStore.transaction` issues
``BEGIN IMMEDIATE`` … ``COMMIT`` itself, so one import is one transaction and a kill
at any point leaves the last committed state (SQLite's journal rolls back the rest).
One :class:`SQLiteStore` belongs to one thread; other threads open their own.

A store that cannot be written -- a read-only file, folder or mount, or one opened
``read_only`` (``history migrate``'s source) -- is opened read-only and never changed: reads
work, every write is one :class:`StoreError`.  Such a store is not migrated in place: one of an
older schema is copied into memory and migrated there.  One opened ``read_only`` is checked
whole first (:func:`check_whole`: every page, every table and column, every text UTF-8), so a
damaged, empty or incomplete source is refused before anything is read from it.

Every public method turns a database failure into one :class:`StoreError` naming the
file and what is wrong with it (:func:`_failure`: damaged, read-only, locked beyond
:data:`BUSY_TIMEOUT_S`, full, I/O error); nothing reaches the caller as a bare
``sqlite3`` or pandas error.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pandas as pd

from setupfix.core.errors import SourceLocation, StoreError
from setupfix.store.audit import TABLES
from setupfix.store.claims import ClaimingStore
from setupfix.store.schema import SCHEMA_VERSION, migrate, rollback, version_of
from setupfix.store.sql import guarded

__all__ = ["SQLiteStore", "BUSY_TIMEOUT_S", "writable", "check_whole"]

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


#: What a write to a store opened read-only is told.
READ_ONLY = (
    "the history store cannot be written (read-only file, folder or file system)",
    "SQLite writes the file and a -wal and -shm file beside it: allow writing both",
)


def writable(path: str) -> bool:
    """Whether this process may write the store ``path`` and the -wal and -shm files beside it."""
    folder = os.path.dirname(os.path.abspath(path))
    return os.access(folder, os.W_OK) and (not os.path.exists(path) or os.access(path, os.W_OK))


def _connect_read_only(path: str) -> sqlite3.Connection:
    """Open ``path`` read-only, never changing it nor leaving a file beside it.

    Without a -wal file beside it (no writer has it open, everything is in the file) the store is
    read as immutable: SQLite then makes no -wal or -shm file.  With one, its committed rows are
    read through it (``mode=ro``); should its -shm file be missing on a read-only folder, as
    immutable after all (nothing can write it there).
    """
    uri = "file:" + quote(os.path.abspath(path))
    tries = ("?mode=ro", "?mode=ro&immutable=1") if os.path.exists(path + "-wal") else ("?mode=ro&immutable=1",)
    for flags in tries:
        db = sqlite3.connect(uri + flags, uri=True, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        try:
            version_of(db)
            return db
        except sqlite3.OperationalError as exc:
            db.close()
            if not str(getattr(exc, "sqlite_errorname", "")).startswith("SQLITE_CANTOPEN") or "immutable" in flags:
                raise
    raise AssertionError("unreachable")


def _quick_check(db: sqlite3.Connection, path: str) -> None:
    if [str(r[0]) for r in db.execute("PRAGMA quick_check")] != ["ok"]:
        raise StoreError(
            "the history store is damaged (not a readable SQLite database)",
            location=SourceLocation(path),
            hint="restore it from a backup, or give another --db/--store",
        )


def check_whole(db: sqlite3.Connection, path: str) -> None:
    """Refuse a store that is damaged (a page, a text that is not UTF-8) or lacks a table or column.

    Raises
    ------
    StoreError
        Naming the store and the table.
    """
    where = SourceLocation(path)
    _quick_check(db, path)
    for table, columns, _ in TABLES:
        have = {str(r[1]) for r in db.execute(f"PRAGMA table_info({table})")}
        missing = [c for c in columns if c not in have]
        if missing:
            what = f"no table {table}" if not have else f"table {table} lacks {', '.join(missing)}"
            raise StoreError(
                f"the history store is incomplete ({what})", location=where, hint="restore it from a backup"
            )
    db.text_factory = bytes
    try:
        for table, columns, order in TABLES:
            for row in db.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY {order}"):
                for value in row:
                    if isinstance(value, bytes):
                        try:
                            value.decode("utf-8")
                        except UnicodeDecodeError:
                            raise StoreError(
                                f"the history store is damaged (text that is not UTF-8 in table {table})",
                                location=where,
                                hint="restore it from a backup",
                            ) from None
    finally:
        db.text_factory = str


def _open_read_only(path: str, *, check: bool) -> sqlite3.Connection:
    """The store ``path`` opened without changing it; an older schema is migrated in a copy in memory."""
    where = SourceLocation(path)
    db = _connect_read_only(path)
    try:
        version = version_of(db)
        if version > SCHEMA_VERSION:
            raise StoreError(
                f"store schema version {version} is newer than this setupfix reads ({SCHEMA_VERSION})",
                location=where,
                hint="update setupfix",
            )
        if version == 0:
            empty = not db.execute("SELECT name FROM sqlite_master WHERE type = 'table'").fetchall()
            raise StoreError(
                "not a setupfix history store (" + ("an empty file)" if empty else "it holds other tables)"),
                location=where,
            )
        if version < SCHEMA_VERSION:
            if check:
                _quick_check(db, path)
            copy = sqlite3.connect(":memory:", isolation_level=None)
            db.backup(copy)
            db.close()
            db = copy
            try:
                migrate(db, path)
            except sqlite3.Error as exc:
                raise StoreError(
                    f"the history store is incomplete or damaged (its schema version {version} cannot be read: {exc})",
                    location=where,
                    hint="restore it from a backup",
                ) from None
        if check:
            check_whole(db, path)
        db.execute("PRAGMA foreign_keys = ON")
        return db
    except BaseException:
        db.close()
        raise


class SQLiteStore(ClaimingStore):
    """:class:`~setupfix.store.Store` in one SQLite file (created and migrated on open).

    ``read_only``: never change the file (and check it whole first); a store this process cannot
    write is opened read-only too (without the whole check).
    """

    errors = (sqlite3.Error, pd.errors.DatabaseError)

    def __init__(self, path: str, *, machine: str, operator: str, read_only: bool = False) -> None:
        self.location, self.machine, self.operator = path, machine, operator
        self._where = SourceLocation(path)
        self._depth = 0
        if path != ":memory:" and not Path(path).parent.is_dir():
            raise StoreError(f"folder {str(Path(path).parent)!r} does not exist", location=self._where)
        if path != ":memory:" and Path(path).exists() and not Path(path).is_file():
            raise StoreError("the history store is not a file", location=self._where, hint="give a file (--db)")
        self.read_only = path != ":memory:" and (read_only or (Path(path).is_file() and not writable(path)))
        if not self.read_only:
            self.db = _connect(path)
            return
        if not Path(path).is_file():
            raise StoreError("no history store here", location=self._where)
        try:
            self.db = _open_read_only(path, check=read_only)
        except sqlite3.Error as exc:
            raise _failure(exc, path) from None

    def _execute(self, sql: str, args: Sequence[Any] = ()) -> sqlite3.Cursor:
        return self.db.execute(sql, args)

    def _executemany(self, sql: str, rows: Iterable[Sequence[Any]]) -> None:
        self.db.executemany(sql, rows)

    def _begin(self) -> None:
        if self.read_only:
            message, hint = READ_ONLY
            raise StoreError(message, location=self._where, hint=hint)
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
        _quick_check(self.db, self.location)
