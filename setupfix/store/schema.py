"""Schema of the SQLite history store, as an ordered list of migrations.

``schema_version`` holds one row: the number of migrations applied.  Opening a store
applies the missing ones in order, each in its own transaction together with the new
version number, so a store is always at one version.  Never edit a released
migration: append a new one.

Creation is atomic: a new store gets ``schema_version`` and every migration in ONE
``BEGIN IMMEDIATE`` transaction, so two processes creating it at once are serialised by
SQLite (the second finds the finished store) and a kill during creation leaves an empty
database, which the next open creates again.  (A temporary file renamed into place was
the other choice; it was not taken because a process that already opened the path would
keep the replaced inode, and SQLite's WAL and lock files are tied to the path.)  A store
left by an older setupfix killed between its ``schema_version`` row and its first
migration (``schema_version`` = 0 and no other table) is completed, not refused.
"""

from __future__ import annotations

import contextlib
import json
import sqlite3
from collections.abc import Callable

from setupfix.core.errors import SourceLocation, StoreError

__all__ = ["MIGRATIONS", "SCHEMA_VERSION", "migrate", "version_of", "rollback"]


def _script(db: sqlite3.Connection, script: str) -> None:
    """Run ``;``-separated statements inside the open transaction.

    ``Connection.executescript`` would commit the pending transaction first; the
    statements here hold no ``;`` inside literals.
    """
    for statement in script.split(";"):
        if statement.strip():
            db.execute(statement)


def _v1(db: sqlite3.Connection) -> None:
    """The first schema: reports, their rows, corrections log, temperatures, recommendations."""
    _script(
        db,
        """
        CREATE TABLE report (
            id INTEGER PRIMARY KEY,
            sha256 TEXT NOT NULL UNIQUE,
            name TEXT NOT NULL,
            format TEXT NOT NULL,
            size INTEGER NOT NULL,
            imported_at TEXT NOT NULL
        );
        CREATE TABLE measurement (
            report_id INTEGER NOT NULL REFERENCES report(id),
            row INTEGER NOT NULL,
            characteristic TEXT NOT NULL, nominal REAL, actual REAL, deviation REAL,
            lower REAL, upper REAL, unit TEXT, part TEXT, report TEXT, timestamp TEXT,
            station TEXT, x REAL, y REAL, z REAL, status TEXT, source TEXT,
            PRIMARY KEY (report_id, row)
        );
        CREATE TABLE correction (
            timestamp TEXT NOT NULL,
            register TEXT NOT NULL,
            delta REAL,
            event TEXT NOT NULL,
            PRIMARY KEY (timestamp, register, event)
        );
        CREATE TABLE temperature (
            timestamp TEXT NOT NULL,
            channel TEXT NOT NULL,
            value REAL NOT NULL,
            PRIMARY KEY (timestamp, channel)
        );
        CREATE TABLE recommendation (
            id INTEGER PRIMARY KEY,
            created_at TEXT NOT NULL,
            optimizer TEXT NOT NULL,
            inputs TEXT NOT NULL,
            result TEXT NOT NULL
        );
    """,
    )


def _v2(db: sqlite3.Connection) -> None:
    """The reference-only flag of a row (``setupfix parse``'s extra column); lookup by part and time."""
    _script(
        db,
        """
        ALTER TABLE measurement ADD COLUMN reference INTEGER NOT NULL DEFAULT 0;
        CREATE INDEX measurement_part ON measurement(part, timestamp);
    """,
    )


def _v3(db: sqlite3.Connection) -> None:
    """Batch claims: which run is correcting a report now, and which reports a batch has processed.

    A row per report (content hash): ``done`` once a batch recommendation for it is stored;
    ``owner`` (a run's random token), ``host``, ``pid``, ``started`` (the process's start
    mark) and ``claimed_at`` while a run holds it.  Filled from the batch recommendations
    already stored (what ``batch --store`` used to read to skip processed reports).
    """
    _script(
        db,
        """
        CREATE TABLE batch_claim (
            report_sha256 TEXT PRIMARY KEY,
            done INTEGER NOT NULL DEFAULT 0,
            owner TEXT, host TEXT, pid INTEGER, started TEXT, claimed_at TEXT
        )
    """,
    )
    done = set()
    for (inputs,) in db.execute("SELECT inputs FROM recommendation"):
        try:
            given = json.loads(inputs)
        except ValueError:
            continue
        if isinstance(given, dict) and given.get("use") == "batch" and given.get("report"):
            done.add(str(given["report"]))
    db.executemany("INSERT INTO batch_claim (report_sha256, done) VALUES (?, 1)", sorted((d,) for d in done))


#: What migration 4 adds, the same on both back ends (the PostgreSQL store writes it with its own types).
V4_TABLES = """
    CREATE TABLE recommendation_delta (
        recommendation_id INTEGER NOT NULL REFERENCES recommendation(id),
        register TEXT NOT NULL,
        delta REAL,
        PRIMARY KEY (recommendation_id, register)
    );
    CREATE INDEX report_machine ON report(machine, id);
    CREATE INDEX recommendation_machine ON recommendation(machine, id);
    CREATE INDEX batch_claim_owner ON batch_claim(owner)
"""


def _v4(db: sqlite3.Connection) -> None:
    """Machine identity and the audit trail.

    Every report, correction, temperature sample and recommendation belongs to one machine
    (rows stored before take ``'default'``, :data:`setupfix.store.DEFAULT_MACHINE`); the
    corrections and temperature keys gain the machine.  A report keeps its row count and
    first and last measured time (a plant summary without reading every row).  A
    recommendation gains its operator and its audit columns (:func:`setupfix.store.audit.audit_of`,
    filled here from the JSON already stored) and one ``recommendation_delta`` row per
    register component.
    """
    from setupfix.store.audit import audit_of

    _script(
        db,
        """
        ALTER TABLE report ADD COLUMN machine TEXT NOT NULL DEFAULT 'default';
        ALTER TABLE report ADD COLUMN rows INTEGER NOT NULL DEFAULT 0;
        ALTER TABLE report ADD COLUMN first_measured TEXT;
        ALTER TABLE report ADD COLUMN last_measured TEXT;
        UPDATE report SET rows = (SELECT count(*) FROM measurement m WHERE m.report_id = report.id),
            first_measured = (SELECT min(timestamp) FROM measurement m WHERE m.report_id = report.id),
            last_measured = (SELECT max(timestamp) FROM measurement m WHERE m.report_id = report.id);
        CREATE TABLE correction_v4 (
            id INTEGER PRIMARY KEY,
            machine TEXT NOT NULL DEFAULT 'default',
            timestamp TEXT NOT NULL,
            register TEXT NOT NULL,
            delta REAL,
            event TEXT NOT NULL,
            UNIQUE (machine, timestamp, register, event)
        );
        INSERT INTO correction_v4 (timestamp, register, delta, event)
            SELECT timestamp, register, delta, event FROM correction ORDER BY rowid;
        DROP TABLE correction;
        ALTER TABLE correction_v4 RENAME TO correction;
        CREATE TABLE temperature_v4 (
            machine TEXT NOT NULL DEFAULT 'default',
            timestamp TEXT NOT NULL,
            channel TEXT NOT NULL,
            value REAL NOT NULL,
            PRIMARY KEY (machine, timestamp, channel)
        );
        INSERT INTO temperature_v4 (timestamp, channel, value) SELECT timestamp, channel, value FROM temperature;
        DROP TABLE temperature;
        ALTER TABLE temperature_v4 RENAME TO temperature;
        ALTER TABLE recommendation ADD COLUMN machine TEXT NOT NULL DEFAULT 'default';
        ALTER TABLE recommendation ADD COLUMN operator TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN report TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN report_sha256 TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN part TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN verdict TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN rules TEXT NOT NULL DEFAULT '[]';
        ALTER TABLE recommendation ADD COLUMN applied INTEGER NOT NULL DEFAULT 0;
        ALTER TABLE recommendation ADD COLUMN exported_to TEXT NOT NULL DEFAULT '';
        ALTER TABLE recommendation ADD COLUMN export_sha256 TEXT NOT NULL DEFAULT ''
    """,
    )
    _script(db, V4_TABLES)
    names = dict(db.execute("SELECT sha256, name FROM report").fetchall())
    for rec_id, inputs, result in db.execute("SELECT id, inputs, result FROM recommendation").fetchall():
        try:
            given, got = json.loads(inputs), json.loads(result)
        except ValueError:
            continue
        if not isinstance(given, dict) or not isinstance(got, dict):
            continue
        a = audit_of(given, got)
        db.execute(
            "UPDATE recommendation SET report = ?, report_sha256 = ?, part = ?, verdict = ?, rules = ?, "
            "applied = ?, exported_to = ?, export_sha256 = ? WHERE id = ?",
            (
                a.report or names.get(a.report_sha256, ""),
                a.report_sha256,
                a.part,
                a.verdict,
                a.rules,
                int(a.applied),
                a.exported_to,
                a.export_sha256,
                rec_id,
            ),
        )
        db.executemany("INSERT INTO recommendation_delta VALUES (?, ?, ?)", [(rec_id, r, d) for r, d in a.deltas])


def _v5(db: sqlite3.Connection) -> None:
    """A report is one machine's record, and may be left out of the history.

    The same bytes measured on two machines are two reports: ``report`` is unique by
    (``machine``, ``sha256``) and a batch claim is keyed by (``machine``, ``report_sha256``)
    (a claim stored before takes its report's machine).  ``report.excluded`` is NULL for a
    report the history uses, else the reason it is left out
    (:data:`setupfix.store.EXCLUDED_REASONS`); reports stored before are used.

    SQLite cannot change a table's UNIQUE constraint: ``report`` is copied aside, dropped and
    created again with the same ids.  The foreign keys of ``measurement`` are deferred to the
    commit meanwhile, and hold again once every id is back.
    """
    db.execute("PRAGMA defer_foreign_keys = ON")
    _script(
        db,
        """
        CREATE TEMP TABLE report_v4 AS SELECT * FROM report;
        DROP TABLE report;
        CREATE TABLE report (
            id INTEGER PRIMARY KEY,
            sha256 TEXT NOT NULL,
            name TEXT NOT NULL,
            format TEXT NOT NULL,
            size INTEGER NOT NULL,
            imported_at TEXT NOT NULL,
            machine TEXT NOT NULL DEFAULT 'default',
            rows INTEGER NOT NULL DEFAULT 0,
            first_measured TEXT,
            last_measured TEXT,
            excluded TEXT,
            UNIQUE (machine, sha256)
        );
        INSERT INTO report (id, sha256, name, format, size, imported_at, machine, rows, first_measured, last_measured)
            SELECT id, sha256, name, format, size, imported_at, machine, rows, first_measured, last_measured
            FROM temp.report_v4 ORDER BY id;
        DROP TABLE temp.report_v4;
        CREATE INDEX report_machine ON report(machine, id);
        CREATE TABLE batch_claim_v5 (
            machine TEXT NOT NULL DEFAULT 'default',
            report_sha256 TEXT NOT NULL,
            done INTEGER NOT NULL DEFAULT 0,
            owner TEXT, host TEXT, pid INTEGER, started TEXT, claimed_at TEXT,
            PRIMARY KEY (machine, report_sha256)
        );
        INSERT INTO batch_claim_v5 (machine, report_sha256, done, owner, host, pid, started, claimed_at)
            SELECT coalesce((SELECT r.machine FROM report r WHERE r.sha256 = c.report_sha256 ORDER BY r.id LIMIT 1),
                'default'), c.report_sha256, c.done, c.owner, c.host, c.pid, c.started, c.claimed_at
            FROM batch_claim c;
        DROP TABLE batch_claim;
        ALTER TABLE batch_claim_v5 RENAME TO batch_claim;
        CREATE INDEX batch_claim_owner ON batch_claim(owner)
    """,
    )


def _v6(db: sqlite3.Connection) -> None:
    """The machine link's audit (:mod:`setupfix.store.link_audit`): one row per ``machine write``
    attempt and one per register component of it (values in the control's unit)."""
    _script(
        db,
        """
        CREATE TABLE link_attempt (
            id INTEGER PRIMARY KEY,
            created_at TEXT NOT NULL,
            machine TEXT NOT NULL DEFAULT 'default',
            operator TEXT NOT NULL DEFAULT '',
            link TEXT NOT NULL,
            plan_sha256 TEXT NOT NULL,
            outcome TEXT NOT NULL,
            message TEXT NOT NULL DEFAULT '',
            unit TEXT NOT NULL
        );
        CREATE TABLE link_component (
            attempt_id INTEGER NOT NULL REFERENCES link_attempt(id),
            position INTEGER NOT NULL,
            register TEXT NOT NULL,
            axis TEXT NOT NULL,
            before REAL, change REAL, written REAL, read_back REAL, restored REAL,
            outcome TEXT NOT NULL,
            PRIMARY KEY (attempt_id, position)
        );
        CREATE INDEX link_attempt_machine ON link_attempt(machine, id)
    """,
    )


#: Migrations in order; migration i (1-based) brings a store from version i − 1 to i.
MIGRATIONS: tuple[Callable[[sqlite3.Connection], None], ...] = (_v1, _v2, _v3, _v4, _v5, _v6)
SCHEMA_VERSION = len(MIGRATIONS)


def version_of(db: sqlite3.Connection) -> int:
    """Schema version of an open store (0: empty database)."""
    tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    if "schema_version" not in tables:
        return 0
    row = db.execute("SELECT version FROM schema_version").fetchone()
    return int(row[0]) if row else 0


def migrate(db: sqlite3.Connection, path: str, *, upto: int = SCHEMA_VERSION) -> int:
    """Apply the missing migrations up to ``upto``; the version reached.

    ``db`` must be in autocommit mode (``isolation_level=None``): each migration runs
    in an explicit ``BEGIN IMMEDIATE`` … ``COMMIT`` with its version bump.

    Raises
    ------
    StoreError
        If the database holds other tables (not a setupfix store) or a newer schema.
    """
    where = SourceLocation(path)
    current = version_of(db)  # a reader does not take the write lock when nothing is to be done
    if current > SCHEMA_VERSION:
        raise StoreError(
            f"store schema version {current} is newer than this setupfix reads ({SCHEMA_VERSION})",
            location=where,
            hint="update setupfix",
        )
    if current >= upto:
        return current
    db.execute("BEGIN IMMEDIATE")
    try:
        version = version_of(db)
        if version == 0:  # new (or left empty by a kill): the whole schema in this one transaction
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if tables - {"schema_version"}:
                raise StoreError("not a setupfix history store (it holds other tables)", location=where)
            if not tables:
                db.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
            db.execute("DELETE FROM schema_version")
            db.execute("INSERT INTO schema_version VALUES (0)")
            _apply(db, 1, upto)
            db.execute("COMMIT")
            return upto
        db.execute("COMMIT")
    except BaseException:
        rollback(db)
        raise
    for number in range(version + 1, upto + 1):
        db.execute("BEGIN IMMEDIATE")
        try:
            if version_of(db) >= number:  # another process migrated meanwhile
                db.execute("COMMIT")
                continue
            _apply(db, number, number)
            db.execute("COMMIT")
        except BaseException:
            rollback(db)
            raise
    return max(version, upto)


def _apply(db: sqlite3.Connection, first: int, last: int) -> None:
    """Migrations ``first`` … ``last`` and the version number, inside the open transaction."""
    for number in range(first, last + 1):
        MIGRATIONS[number - 1](db)
    db.execute("UPDATE schema_version SET version = ?", (last,))


def rollback(db: sqlite3.Connection) -> None:
    """Roll back if a transaction is open (a failed COMMIT may have ended it already); never raises."""
    if db.in_transaction:
        with contextlib.suppress(sqlite3.Error):
            db.execute("ROLLBACK")
