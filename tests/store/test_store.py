"""The history store: idempotent imports, one transaction per import, migrations, concurrent readers.

Every test that takes ``location`` runs on both back ends (a file, and a new database on the test
PostgreSQL server: :mod:`pgserver`); the others are about the SQLite file itself.
"""

from __future__ import annotations

import hashlib
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.cli import main
from setupfix.core.errors import ParseError, StoreError
from setupfix.model import CANONICAL_COLUMNS
from setupfix.store import Recommendation, open_store
from setupfix.store.schema import SCHEMA_VERSION, migrate, version_of
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.usecases.parse import parse_reports

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REPORTS = sorted(GUIDE.glob("cycle_0*.csv"))
TEMPS = ROOT / "sample_reports" / "thermal" / "test_constant.csv"
LOG = "timestamp,register,delta,event\n2026-11-02T09:00:00,G54,0.012,\n2026-11-03T07:00:00,T23,,tool_change\n"


def _counts(path: str | Path) -> tuple[int, int, int, int]:
    with open_store(path) as s:
        return len(s.reports()), len(s.measurements()), len(s.corrections()), len(s.temperatures())


def _log(tmp_path: Path, text: str = LOG, name: str = "corr.csv") -> Path:
    (tmp_path / name).write_text(text)
    return tmp_path / name


def test_import_twice_changes_nothing_and_rows_come_back(tmp_path: Path, location: str) -> None:
    db, log = location, _log(tmp_path)
    with open_store(db) as store:
        first = import_history(store, ImportRequest(tuple(REPORTS), (log,), (TEMPS,)))
        again = import_history(store, ImportRequest(tuple(REPORTS), (log,), (TEMPS,)))
        assert len(first.new_reports) == 5 and first.corrections == 2 and first.temperatures > 0
        assert list(again.new_reports) == [] and len(again.known_reports) == 5
        assert again.corrections == again.temperatures == 0
        back = store.measurements()
    table = parse_reports(REPORTS).table
    np.testing.assert_array_equal(back["deviation"].to_numpy(float), table["deviation"].to_numpy(float))
    for col in CANONICAL_COLUMNS:
        if not pd.api.types.is_numeric_dtype(table[col]):
            assert back[col].fillna("").tolist() == table[col].fillna("").astype(str).tolist(), col
    assert _counts(db) == (5, 140, 2, len(pd.read_csv(TEMPS)))


def test_logs_round_trip_and_contradictions_are_refused(tmp_path: Path, location: str) -> None:
    db = location
    with open_store(db) as store:
        import_history(store, ImportRequest(corrections=(_log(tmp_path),), temperatures=(TEMPS,)))
        log = store.corrections()
        assert log.to_dict("list")["register"] == ["G54", "T23"]
        assert log["delta"].iloc[0] == 0.012 and np.isnan(log["delta"].iloc[1])
        assert store.corrections("tool_change")["register"].tolist() == ["T23"]
        temps, source = store.temperatures(), pd.read_csv(TEMPS)
        for col in temps.columns.drop("timestamp"):
            np.testing.assert_array_equal(temps[col].to_numpy(), source[col].to_numpy(float))
        other = _log(tmp_path, LOG.replace("0.012", "0.013"), "other.csv")
        with pytest.raises(StoreError, match=r"G54.*contradicts the stored one"):
            import_history(store, ImportRequest(tuple(REPORTS), (other,)))
        twice = _log(tmp_path, LOG + "2026-11-02T09:00:00,G54,0.02,\n", "twice.csv")
        with pytest.raises(
            ParseError,
            match=r"twice.csv:4: G54 correction at 2026-11-02T09:00:00 given twice "
            r"\(also at line 2\)",
        ):  # the reader names it, as every door does
            import_history(store, ImportRequest(corrections=(twice,)))
    assert _counts(db)[:3] == (0, 0, 2)  # the reports of the refused import were not stored either


def test_a_bad_file_stores_nothing(tmp_path: Path, location: str) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("characteristic,nominal,actual\nD1,1.0,abc\n")
    with open_store(location) as store:
        with pytest.raises(ParseError, match=r"bad.csv:2"):
            import_history(store, ImportRequest((*REPORTS, bad)))
        with pytest.raises(ParseError, match=r"corr.csv:3: unknown event"):
            import_history(store, ImportRequest(tuple(REPORTS), (_log(tmp_path, LOG.replace("tool_change", "wear")),)))
        assert store.reports() == []


KILL = """
import os, signal, sys
import pandas as pd
from setupfix.store import open_store
store = open_store(sys.argv[1])
with store.transaction():  # what one import does: reports, then the logs
    store.add_report(b"second report", "r2.csv", "canonical",
                     pd.DataFrame({"characteristic": ["D1"], "nominal": [1.0], "actual": [1.01]}))
    store.add_corrections(pd.DataFrame({"timestamp": ["2026-01-01T00:00:00"], "register": ["G54"],
                                        "delta": [0.01], "event": ["correction"]}))
    os.kill(os.getpid(), signal.SIGKILL)  # written, not committed
"""


@pytest.mark.slow
def test_kill_during_import_leaves_the_store_as_it_was(location: str) -> None:
    db = location
    with open_store(db) as store:
        import_history(store, ImportRequest(tuple(REPORTS[:1])))
    args = [sys.executable, "-c", KILL, str(db)]
    proc = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert _counts(db) == (1, 28, 0, 0)
    if not db.startswith("postgresql://"):
        with sqlite3.connect(db) as raw:
            assert raw.execute("PRAGMA integrity_check").fetchone() == ("ok",)


READER = """
import sys
from setupfix.store import open_store
with open_store(sys.argv[1]) as s:
    print(len(s.reports()), len(s.measurements()))
"""


@pytest.mark.slow
def test_readers_see_the_last_commit_while_another_process_writes(location: str) -> None:
    db = location
    with open_store(db) as store:
        import_history(store, ImportRequest(tuple(REPORTS[:1])))
        with store.transaction():
            store.add_report(REPORTS[1].read_bytes(), "c2", "canonical", parse_reports(REPORTS[1:2]).table)
            out = subprocess.run(
                [sys.executable, "-c", READER, str(db)], cwd=ROOT, capture_output=True, text=True, timeout=20
            )  # must not wait for the writer (WAL, MVCC)
            assert out.stdout.split() == ["1", "28"], out.stderr
        with open_store(db) as reader:
            assert len(reader.reports()) == 2 and len(reader.measurements()) == 56


def test_migration_from_the_first_schema_keeps_the_data(tmp_path: Path) -> None:
    db = tmp_path / "old.db"
    raw = sqlite3.connect(db, isolation_level=None)
    assert migrate(raw, str(db), upto=1) == 1
    raw.execute("INSERT INTO report VALUES (1, 'abc', 'old.csv', 'canonical', 10, '2026-01-01T00:00:00')")
    raw.execute("INSERT INTO measurement (report_id, row, characteristic, deviation) VALUES (1, 0, 'D1', 0.5)")
    raw.execute("INSERT INTO correction VALUES ('2026-01-01T00:00:00', 'G54', 0.1, 'correction')")
    raw.close()
    with open_store(db) as store:
        assert version_of(store.db) == SCHEMA_VERSION  # type: ignore[attr-defined]
        rows = store.measurements()
        assert rows["characteristic"].tolist() == ["D1"] and rows["reference"].tolist() == [False]
        assert store.corrections()["delta"].tolist() == [0.1]


def test_what_is_not_a_store_is_refused(tmp_path: Path) -> None:
    (tmp_path / "text.db").write_text("hello, this is not SQLite" * 100)
    with pytest.raises(StoreError, match=r"text.db"):
        open_store(tmp_path / "text.db")
    other = sqlite3.connect(tmp_path / "other.db")
    other.execute("CREATE TABLE x (y)")
    other.commit()
    other.close()
    with pytest.raises(StoreError, match="not a setupfix history store"):
        open_store(tmp_path / "other.db")
    with open_store(tmp_path / "new.db") as store:
        store.db.execute("UPDATE schema_version SET version = 99")  # type: ignore[attr-defined]
    with pytest.raises(StoreError, match="newer"):
        open_store(tmp_path / "new.db")
    with pytest.raises(StoreError, match="does not exist"):
        open_store(tmp_path / "missing" / "h.db")


def test_recommendations_round_trip(location: str) -> None:
    with open_store(location, machine="M7", operator="ana") as store:
        rec = Recommendation("exact", {"report": "abc", "part": "1", "seed": None}, {"corrections": {"G54": 0.01}})
        store.add_recommendation(rec)
        (back,) = store.recommendations()
        assert (back.optimizer, back.inputs, back.result) == (rec.optimizer, rec.inputs, rec.result)
        assert back.created_at and (back.machine, back.operator) == ("M7", "ana")


def test_cli_import_show_export(tmp_path: Path, capsys: pytest.CaptureFixture[str], location: str) -> None:
    db = location
    assert main(["history", "import", "--db", db, *map(str, REPORTS), "--corrections", str(_log(tmp_path))]) == 0
    assert main(["history", "show", "--db", db, "--json"]) == 0
    capsys.readouterr()
    assert main(["history", "export", "measurements", "--db", db, "--out", str(tmp_path / "m.csv")]) == 0
    assert main(["history", "export", "corrections", "--db", db, "--out", "-"]) == 0
    assert capsys.readouterr().out.splitlines()[1] == "2026-11-02T09:00:00,G54,0.012,correction"
    assert (
        main(["correct", "--model", str(GUIDE / "model.toml"), str(tmp_path / "m.csv"), "--part", "cycle 03", "--json"])
        == 0
    )
    assert main(["history", "export", "corrections", "--db", db, "--out", str(tmp_path)]) == 1
    assert "folder" in capsys.readouterr().err


def test_recommendations_of_a_correct_run_are_stored(location: str) -> None:
    from setupfix.model import load_model
    from setupfix.usecases.contract import cycle_json
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.history import record_recommendations
    from setupfix.usecases.requests import CorrectRequest

    results = correct_report(CorrectRequest(load_model(GUIDE / "model.toml")), REPORTS[0]).cycles
    with open_store(location) as store:
        record_recommendations(store, results, model=GUIDE / "model.toml", report=REPORTS[0])
        (rec,) = store.recommendations()
    assert rec.optimizer == "exact" and rec.result["corrections"] == cycle_json(results[0])["corrections"]
    assert rec.inputs["report_sha256"] == hashlib.sha256(REPORTS[0].read_bytes()).hexdigest()


def test_a_truncated_report_is_refused_and_nothing_stored(tmp_path: Path, location: str) -> None:
    cut = tmp_path / "cut.csv"
    cut.write_bytes(REPORTS[0].read_bytes()[:322])  # ends inside a row: "P1 D4,30.0000,29."
    with open_store(location) as store:
        with pytest.raises(ParseError, match=r"cut.csv.*truncated"):
            import_history(store, ImportRequest((REPORTS[1], cut)))
        assert store.reports() == []


def test_the_store_keeps_the_corrections_log_in_its_readers_columns() -> None:
    from parsers.corrections import COLUMNS
    from setupfix.store import CORRECTION_COLUMNS

    assert CORRECTION_COLUMNS is COLUMNS  # one definition
