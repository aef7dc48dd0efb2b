"""Issue 25: one history for the whole plant -- machines, the audit trail, migrate, many writers on a server.

Real processes on a real PostgreSQL server (``SETUPFIX_TEST_PG``, :mod:`pgserver`) and SQLite
files; the row counts are compared with what was given, never with what the store says of itself.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from setupfix.cli import main
from setupfix.core.errors import StoreError
from setupfix.store import AUDIT_COLUMNS, Recommendation, open_store, report_tables, stored_corrections
from setupfix.store.audit import TABLES
from setupfix.store.link_audit import LinkAttempt, LinkComponentRecord
from setupfix.store.schema import migrate
from setupfix.usecases.history import ImportRequest, import_history

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
MODEL = GUIDE / "model.toml"
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def machine_reports(folder: Path, machine: str, n: int) -> list[Path]:
    """``n`` distinct guide-pin reports of one machine (part names and times of their own)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for k in range(n):
        text = (GUIDE / f"cycle_0{k % 5 + 1}.csv").read_text()
        text = text.replace(f"cycle 0{k % 5 + 1}", f"{machine} part {k:03d}")
        path = folder / f"{machine}_{k:03d}.csv"
        path.write_text(text)
        out.append(path)
    return out


def log_of(folder: Path, machine: str) -> Path:
    path = folder / f"{machine}_corrections.csv"
    path.write_text(
        f"timestamp,register,delta,event\n2026-11-01T06:00:00,G54,{0.001 * (1 + len(machine))},\n"
        "2026-11-03T07:00:00,T23,,tool_change\n"
    )
    return path


IMPORT = """
import sys, time
from pathlib import Path
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.store import open_store
url, machine, start, log, *files = sys.argv[1:]
time.sleep(max(0.0, float(start) - time.time()))
with open_store(url, machine=machine) as store:
    s = import_history(store, ImportRequest(tuple(files), (log,)))
print(len(s.new_reports), s.corrections)
"""


def test_eight_processes_importing_into_one_server_lose_and_double_nothing(tmp_path: Path, pg_url: str) -> None:
    """Eight processes, two per machine, import overlapping report sets at once; then all of it again."""
    machines = ["M1", "M2", "M3", "M4"]
    given = {m: machine_reports(tmp_path / m, m, 12) for m in machines}
    open_store(pg_url).close()  # the schema (its creation at once is another test)

    def wave() -> list[tuple[int, int]]:
        import time

        start = time.time() + 2.0
        procs = []
        for i in range(8):
            m = machines[i % 4]
            files = given[m][:8] if i < 4 else given[m][4:]  # the two processes of a machine overlap in 4 reports
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-c", IMPORT, pg_url, m, str(start), str(log_of(tmp_path, m)), *map(str, files)],
                    env=ENV,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    text=True,
                )
            )
        results = [p.communicate(timeout=300) for p in procs]
        assert [p.returncode for p in procs] == [0] * 8, [err for _, err in results]
        return [tuple(map(int, out.split())) for out, _ in results]  # type: ignore[misc]

    first = wave()
    assert sum(n for n, _ in first) == 4 * 12  # each report stored by exactly one of the processes
    assert sum(c for _, c in first) == 4 * 2  # each log row once
    for m in machines:
        with open_store(pg_url, machine=m) as store:
            names = sorted(r.name for r in store.reports())
            assert names == sorted(p.name for p in given[m])
            rows = store.measurements()
            assert len(rows) == 12 * 28 and rows["part"].str.startswith(f"{m} part").all()
            assert store.corrections()["register"].tolist() == ["G54", "T23"]
    assert wave() == [(0, 0)] * 8  # a re-run adds nothing
    with open_store(pg_url) as store:
        assert store.count("report") == 48 and store.count("measurement") == 48 * 28
        assert store.count("correction") == 8


BATCH_MACHINES = 8


def test_eight_batches_at_once_on_one_server_correct_each_report_once_and_a_rerun_adds_nothing(
    tmp_path: Path, pg_url: str
) -> None:
    n = 24
    folder = tmp_path / "reports"
    machine_reports(folder, "plant", n)
    open_store(pg_url).close()

    def run_all() -> list[dict[str, object]]:
        procs = [
            subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "setupfix",
                    "batch",
                    str(folder),
                    "--model",
                    str(MODEL),
                    "--out",
                    str(tmp_path / f"out{i}.csv"),
                    "--store",
                    pg_url,
                    "--settle",
                    "0",
                    "--workers",
                    "1",
                    "--json",
                ],
                env=ENV,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            for i in range(BATCH_MACHINES)
        ]
        results = [p.communicate(timeout=600) for p in procs]
        assert [p.returncode for p in procs] == [0] * BATCH_MACHINES, [err for _, err in results]
        return [json.loads(out) for out, _ in results]

    summaries = run_all()
    assert sum(s["reports"] for s in summaries) == n  # type: ignore[misc]
    with open_store(pg_url) as store:
        recs = [r.inputs["report"] for r in store.recommendations()]
        assert len(recs) == n and len(set(recs)) == n  # corrected once in total, nothing doubled
        assert store.count("report") == n and store.count("measurement") == n * 28
        claims = list(store.dump("batch_claim"))
        assert len(claims) == n and all(c[2] == 1 and c[3] is None for c in claims)
    again = run_all()
    assert sum(s["reports"] for s in again) == 0  # type: ignore[misc]
    with open_store(pg_url) as store:
        assert len(store.recommendations()) == n and store.count("report") == n


def test_each_machine_reads_only_its_own_rows(tmp_path: Path, location: str) -> None:
    temps = tmp_path / "t.csv"
    for m, delta in (("M1", 0.01), ("M2", 0.02)):
        temps.write_text(f"timestamp,spindle\n2026-11-02T08:00:00,{20 + delta}\n")
        log = tmp_path / f"{m}.csv"
        log.write_text(f"timestamp,register,delta,event\n2026-11-02T07:00:00,G54,{delta},\n")
        with open_store(location, machine=m) as store:
            import_history(store, ImportRequest(tuple(machine_reports(tmp_path / m, m, 3)), (log,), (temps,)))
            store.add_recommendation(
                Recommendation("exact", {"part": f"{m} part 000"}, {"corrections": {"G54": delta}})
            )
    from setupfix.model import load_model

    model = load_model(MODEL)
    for m, delta in (("M1", 0.01), ("M2", 0.02)):
        with open_store(location, machine=m) as store:
            tables = report_tables(store)  # what correct --store, diagnose --db and the TUI read
            assert len(tables) == 3 and all(t["part"].str.startswith(m).all() for _, t in tables)
            stored = stored_corrections(store, model)
            assert stored is not None and stored.deltas.tolist() == [delta]
            assert store.temperatures()["spindle"].tolist() == [20 + delta]
            assert [r.result["corrections"] for r in store.recommendations()] == [{"G54": delta}]
            assert len(store.audit()) == 1 and len(store.audit(every_machine=True)) == 2
    with open_store(location, machine="M3") as store:
        assert store.reports() == [] and store.measurements().empty and store.corrections().empty
        summary = {s.machine: s for s in store.machines()}
    assert sorted(summary) == ["M1", "M2"]
    assert all(
        (s.reports, s.rows, s.corrections, s.temperature_samples, s.recommendations) == (3, 84, 1, 1, 1)
        for s in summary.values()
    )


def test_a_report_belongs_to_one_machine(tmp_path: Path, location: str) -> None:
    """The same bytes measured on two machines are two records, each read by its own machine only."""
    report = machine_reports(tmp_path, "M1", 1)
    for m in ("M1", "M2", "M1"):
        with open_store(location, machine=m) as store:
            import_history(store, ImportRequest(tuple(report)))
    for m in ("M1", "M2"):
        with open_store(location, machine=m) as store:
            assert [(r.machine, r.name) for r in store.reports()] == [(m, "M1_000.csv")]
            assert len(store.measurements()) == 28
    with open_store(location, machine="M3") as store:
        assert store.reports() == [] and store.measurements().empty


def _fill(db: str, tmp_path: Path) -> None:
    """A store with every kind of row: reports of two machines, logs, recommendations of three doors, claims."""
    for m in ("M1", "M2"):
        with open_store(db, machine=m, operator="ana") as store:
            import_history(
                store,
                ImportRequest(
                    tuple(machine_reports(tmp_path / m, m, 3)),
                    (log_of(tmp_path, m),),
                    (ROOT / "sample_reports" / "thermal" / "test_constant.csv",),
                ),
            )
    out = tmp_path / "o.csv"
    machine_reports(tmp_path / "B", "B", 3)
    assert (
        main(["batch", str(tmp_path / "B"), "--model", str(MODEL), "--out", str(out), "--store", db, "--settle", "0"])
        == 0
    )  # (batch's --machine comes with the wiring: its rows are 'default')
    from setupfix.model import load_model
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.history import record_recommendations
    from setupfix.usecases.requests import CorrectRequest

    report = tmp_path / "M2" / "M2_000.csv"
    results = correct_report(CorrectRequest(load_model(MODEL)), report).cycles
    with open_store(db, machine="M2", operator="bo") as store:
        record_recommendations(store, results, model=MODEL, report=report)
        store.add_recommendation(
            Recommendation(
                "exact",
                {
                    "report": "M2_000.csv",
                    "part": "M2 part 000",
                    "applied": True,
                    "export": {"target": "o.nc", "controller": "fanuc", "sha256": "ab" * 32},
                },
                {"verdict": "apply", "corrections": {"W1": 0.01, "T5": -0.002}},
            )
        )
        store.add_link_attempt(  # a machine write's audit (schema 6): an attempt and its components
            LinkAttempt(
                link="opc.tcp://127.0.0.1:4840 (mc.toml)",
                plan_sha256="cd" * 32,
                outcome="applied",
                message="read back",
                unit="mm",
                components=(LinkComponentRecord("G54", "Z", -412.53, -0.023, -412.553, -412.553, None, "confirmed"),),
            )
        )


def test_migrate_copies_every_row(tmp_path: Path, pg_url: str, capsys: pytest.CaptureFixture[str]) -> None:
    source = str(tmp_path / "plant.db")
    _fill(source, tmp_path)
    assert main(["history", "migrate", "--from", source, "--db", pg_url]) == 0
    assert "127.0.0.1" in capsys.readouterr().out
    with open_store(source) as a, open_store(pg_url) as b:
        for table, _, _ in TABLES:
            rows_a, rows_b = list(a.dump(table)), list(b.dump(table))
            assert rows_a == rows_b, table
            assert len(rows_a) > 0, table  # every table was filled, so every table was copied
        assert {t for t, _, _ in TABLES} >= {"link_attempt", "link_component"}  # the machine link's audit too
        # the copy is a working store: ids go on after the copied ones
        b.add_recommendation(Recommendation("exact", {}, {}))
        assert b.count("recommendation") == a.count("recommendation") + 1
    with sqlite3.connect(source) as raw:  # and the counts the source file itself gives
        for table, _, _ in TABLES:
            with open_store(pg_url) as b:
                assert raw.execute(f"SELECT count(*) FROM {table}").fetchone()[0] == b.count(table) - (
                    table == "recommendation"
                )
    raw.close()
    assert main(["history", "migrate", "--from", source, "--db", pg_url]) == 1  # never into a store in use
    assert "already holds" in capsys.readouterr().err


@pytest.mark.slow
def test_the_audit_export_holds_every_recommendation(
    tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]
) -> None:
    _fill(location, tmp_path)
    out = tmp_path / "audit.csv"
    assert main(["history", "export", "recommendations", "--db", location, "--out", str(out)]) == 0
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert list(rows[0]) == list(AUDIT_COLUMNS)
    with open_store(location) as store:
        batch = store.recommendations()  # the 'default' machine's: the batch
        shas = {r.sha256: r.name for r in store.reports()}
    assert len(batch) == 3
    by_machine = {m: [r for r in rows if r["machine"] == m] for m in ("default", "M2")}
    for rec in batch:  # one CSV row per register component, with the report's hash and name
        mine = [r for r in by_machine["default"] if r["report_sha256"] == rec.inputs["report"]]
        assert {r["register"]: float(r["delta"]) for r in mine} == rec.result["corrections"]
        assert {r["verdict"] for r in mine} == {rec.result["verdict"]}
        assert {r["report"] for r in mine} == {shas[rec.inputs["report"]]}
    correct_rows = [r for r in by_machine["M2"] if r["applied"] == "False"]
    report = tmp_path / "M2" / "M2_000.csv"
    assert {r["report_sha256"] for r in correct_rows} == {hashlib.sha256(report.read_bytes()).hexdigest()}
    assert {r["operator"] for r in by_machine["M2"]} == {"bo"} and {r["verdict"] for r in correct_rows} == {"apply"}
    applied = [r for r in by_machine["M2"] if r["applied"] == "True"]
    assert sorted((r["register"], float(r["delta"]), r["exported_to"]) for r in applied) == [
        ("T5", -0.002, "o.nc"),
        ("W1", 0.01, "o.nc"),
    ]
    capsys.readouterr()
    assert main(["history", "export", "recommendations", "--db", location, "--machine", "M2", "--out", "-"]) == 0
    only = pd.read_csv(io.StringIO(capsys.readouterr().out))
    assert set(only["machine"]) == {"M2"} and len(only) == len(by_machine["M2"])


def test_history_show_summarises_per_machine(tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]) -> None:
    for m in ("M1", "M2"):
        assert (
            main(
                [
                    "history",
                    "import",
                    "--db",
                    location,
                    "--machine",
                    m,
                    *map(str, machine_reports(tmp_path / m, m, 2 + (m == "M2"))),
                ]
            )
            == 0
        )
    capsys.readouterr()
    assert main(["history", "show", "--db", location, "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)
    assert [(m["machine"], m["reports"], m["rows"]) for m in shown["machines"]] == [("M1", 2, 56), ("M2", 3, 84)]
    assert "reports" not in shown
    assert main(["history", "show", "--db", location, "--machine", "M2"]) == 0
    text = capsys.readouterr().out
    assert "machine M2: 3 report(s)" in text and "M2_002.csv" in text and "M1_000.csv" not in text


def test_a_v3_store_migrates_with_its_audit(tmp_path: Path) -> None:
    """A store of the previous schema gains machine 'default' and the audit columns of what it holds."""
    path = tmp_path / "v3.db"
    con = sqlite3.connect(path, isolation_level=None)
    migrate(con, str(path), upto=3)
    con.execute("INSERT INTO report VALUES (1, ?, 'c1.csv', 'canonical', 10, '2026-01-01T00:00:00')", ("a" * 64,))
    con.execute(
        "INSERT INTO measurement (report_id, row, characteristic, deviation, timestamp) "
        "VALUES (1, 0, 'D1', 0.5, '2026-01-01T08:00:00')"
    )
    con.execute("INSERT INTO correction VALUES ('2026-01-01T00:00:00', 'G54', 0.1, 'correction')")
    con.execute("INSERT INTO temperature VALUES ('2026-01-01T00:00:00', 'spindle', 21.5)")
    con.execute(
        "INSERT INTO recommendation (created_at, optimizer, inputs, result) VALUES ('2026-01-02', 'exact', "
        f"'{json.dumps({'use': 'batch', 'report': 'a' * 64, 'part': 'p1'})}', "
        f"'{json.dumps({'verdict': 'hold', 'corrections': {'G54': 0.003, 'T5': 0.0}})}')"
    )
    con.close()
    with open_store(path) as store:
        assert [r.machine for r in store.reports()] == ["default"] and store.reports()[0].rows == 1
        assert store.corrections()["delta"].tolist() == [0.1]
        assert store.temperatures()["spindle"].tolist() == [21.5]
        audit = store.audit()
    assert audit[["report", "report_sha256", "part", "verdict", "register", "delta"]].values.tolist() == [
        ["c1.csv", "a" * 64, "p1", "hold", "G54", 0.003],
        ["c1.csv", "a" * 64, "p1", "hold", "T5", 0.0],
    ]


def test_what_is_not_a_store_on_a_server_is_refused(pg_url: str) -> None:
    import psycopg

    with psycopg.connect(pg_url, autocommit=True) as con:
        con.execute("CREATE TABLE other (x int)")
    with pytest.raises(StoreError, match="not a setupfix history store"):
        open_store(pg_url)
    with psycopg.connect(pg_url, autocommit=True) as con:
        con.execute("DROP TABLE other")
    with open_store(pg_url) as store:
        store._execute("UPDATE schema_version SET version = 99")  # type: ignore[attr-defined]
    with pytest.raises(StoreError, match="newer"):
        open_store(pg_url)


def test_server_failures_are_one_line_naming_the_store_without_its_password(
    pg_url: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from urllib.parse import urlsplit

    password = urlsplit(pg_url).password
    assert password
    wrong = pg_url.replace(f":{password}@", ":not-the-password@")
    down = "postgresql://setupfix:s3cret-pw@127.0.0.1:1/setupfix_test"
    cases = {
        "refused the login": wrong,
        "cannot reach": down,
        "no such database": pg_url.rsplit("/", 1)[0] + "/nope",
        "not a PostgreSQL URL": "postgresql://setupfix:s3cret-pw@[::1/x",
    }
    for what, url in cases.items():
        for argv in (
            ["history", "show", "--db", url],
            ["history", "import", "--db", url, str(GUIDE / "cycle_01.csv")],
            ["batch", str(GUIDE), "--model", str(MODEL), "--out", "-", "--store", url],
        ):
            capsys.readouterr()
            assert main(argv) == 1, (what, argv)
            err = capsys.readouterr().err
            assert "Traceback" not in err and "internal error" not in err
            lines = [x for x in err.splitlines() if x.startswith("error:")]
            assert len(lines) == 1 and what in lines[0], (what, err)
            assert "postgresql://setupfix@" in lines[0] or "postgresql://" in lines[0]
            assert password not in err and "not-the-password" not in err and "s3cret-pw" not in err, err
