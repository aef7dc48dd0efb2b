"""Migration 5 (issue 37 items 1 and 15): a store of schema 4 keeps its reports in the history, its claims
take their report's machine, and the same bytes may then be stored for another machine -- on SQLite and on
PostgreSQL alike (each back end's migration 4 applied by hand, then a v5 setupfix opens the store)."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pandas as pd

from setupfix.store import open_store
from setupfix.store.postgres import MIGRATIONS as PG_MIGRATIONS
from setupfix.store.schema import SCHEMA_VERSION, migrate

SHA = "d" * 64
ROWS = (
    (
        "INSERT INTO report (id, sha256, name, format, size, imported_at, machine) "
        "VALUES (7, ?, 'r7.csv', 'canonical', 9, '2026-01-01T00:00:00', 'M4')"
    ),
    "INSERT INTO measurement (report_id, row, characteristic, deviation) VALUES (7, 0, 'D1', 0.04)",
    "INSERT INTO batch_claim (report_sha256, done) VALUES (?, 1)",
    "INSERT INTO batch_claim (report_sha256, done) VALUES (?, 1)",
)
ARGS: tuple[tuple[str, ...], ...] = ((SHA,), (), (SHA,), ("e" * 64,))


def v4(location: str) -> None:
    """Schema 4 at ``location`` with a report of machine M4, its claim, and a claim of no stored report."""
    if location.startswith("postgresql"):
        import psycopg

        with psycopg.connect(location, autocommit=True) as con:
            con.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
            con.execute("INSERT INTO schema_version VALUES (4)")
            for script in PG_MIGRATIONS[:4]:
                for statement in script.split(";"):
                    if statement.strip():
                        con.execute(statement)
            for sql, args in zip(ROWS, ARGS, strict=True):
                con.execute(sql.replace("?", "%s"), args)
        return
    db = sqlite3.connect(location, isolation_level=None)
    migrate(db, location, upto=4)
    for sql, args in zip(ROWS, ARGS, strict=True):
        db.execute(sql, args)
    db.close()


def test_a_v4_store_is_migrated_on_both_back_ends(tmp_path: Path, location: str) -> None:
    v4(location)
    with open_store(location, machine="M4") as store:
        assert store.count("schema_version") == 1
        assert [(r.name, r.excluded) for r in store.reports()] == [("r7.csv", None)]
        assert store.measurements()["deviation"].tolist() == [0.04]
        assert sorted(c[:3] for c in store.dump("batch_claim")) == [("M4", SHA, 1), ("default", "e" * 64, 1)]
        version = store._one("SELECT version FROM schema_version")  # type: ignore[attr-defined]
        assert version == (SCHEMA_VERSION,)
    table = pd.DataFrame({"characteristic": ["D1"], "deviation": [0.05]})
    with open_store(location, machine="M5") as store:  # the same bytes for another machine: a record of its own
        store.add_report(b"another machine's copy", "r7.csv", "canonical", table)
        store._execute(  # type: ignore[attr-defined]
            "INSERT INTO report (sha256, name, format, size, imported_at, machine) "
            "VALUES (?, 'r7.csv', 'canonical', 9, '2026-01-02T00:00:00', 'M5')",
            (SHA,),
        )
        assert sorted(r.sha256 for r in store.reports())[-1] == SHA
    with open_store(location, machine="M4") as store:
        assert [r.machine for r in store.reports()] == ["M4"]
