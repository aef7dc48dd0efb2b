"""Issue 37 items 17 (a store on a read-only mount cannot even be read) and 15, fourth bullet (``history
migrate`` on a damaged, empty or older source).

Variants of the issue's cases: a store of five guide-pin reports and a store of the previous schema (v4)
on a read-only bind mount (root) or a read-only folder (other users); sources for a copy that are empty, cut
short, hold a report name that is not UTF-8, lack a table, or are of schema v3 -- each opened read-only is
refused in one StoreError or read as it is, and its bytes never change.
"""

from __future__ import annotations

import hashlib
import os
import sqlite3
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.core.errors import StoreError
from setupfix.store import open_store, report_tables
from setupfix.store.schema import SCHEMA_VERSION, migrate, version_of
from setupfix.usecases.history import ImportRequest, import_history, migrate_history

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REPORTS = sorted(GUIDE.glob("cycle_0*.csv"))


def digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


@pytest.fixture
def frozen(tmp_path: Path) -> Iterator[Callable[[Path], Path]]:
    """``freeze(folder)``: the folder as a read-only mount (root) or read-only folder and files (others)."""
    undo: list[list[str]] = []
    modes: list[tuple[Path, int]] = []

    def freeze(folder: Path) -> Path:
        if os.geteuid() == 0:
            seen = tmp_path / f"ro_{folder.name}"
            seen.mkdir()
            for cmd in (["mount", "--bind", str(folder), str(seen)], ["mount", "-o", "remount,ro,bind", str(seen)]):
                done = subprocess.run(cmd, capture_output=True, text=True)
                if done.returncode:
                    if undo:
                        subprocess.run(undo.pop(), capture_output=True)
                    pytest.skip(f"cannot make a read-only mount here: {done.stderr.strip()}")
                if cmd[1] == "--bind":
                    undo.append(["umount", str(seen)])
            return seen
        for p in [*folder.iterdir(), folder]:
            modes.append((p, p.stat().st_mode))
            p.chmod(0o555 if p.is_dir() else 0o444)
        return folder

    yield freeze
    for cmd in undo:
        subprocess.run(cmd, capture_output=True)
    for p, mode in reversed(modes):
        p.chmod(mode)


def v4_store(path: Path) -> None:
    """A store of the previous schema holding one report of machine M1."""
    con = sqlite3.connect(path, isolation_level=None)
    migrate(con, str(path), upto=4)
    con.execute(
        "INSERT INTO report (id, sha256, name, format, size, imported_at, machine) "
        "VALUES (1, ?, 'old.csv', 'canonical', 10, '2026-01-01T00:00:00', 'M1')",
        ("b" * 64,),
    )
    con.execute("INSERT INTO measurement (report_id, row, characteristic, deviation) VALUES (1, 0, 'D1', 0.02)")
    con.execute("PRAGMA journal_mode = WAL")
    con.close()


def test_a_store_on_a_read_only_mount_is_read_and_every_write_is_one_clear_refusal(
    tmp_path: Path, frozen: Callable[[Path], Path], capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "plant"
    folder.mkdir()
    with open_store(folder / "h.db", machine="M1") as store:
        import_history(store, ImportRequest(tuple(REPORTS[:4])))
    v4_store(folder / "old.db")
    before = digest(folder)
    seen = frozen(folder)
    with open_store(seen / "h.db", machine="M1") as store:
        assert [r.name for r, _ in report_tables(store)] == [p.name for p in REPORTS[:4]]
        assert len(store.measurements()) == 4 * 28
        store.verify()
        with pytest.raises(StoreError, match="cannot be written"):
            import_history(store, ImportRequest((REPORTS[4],)))
    with open_store(seen / "old.db", machine="M1") as store:  # an older schema is read as it is, not migrated
        assert [(r.name, r.excluded) for r in store.reports()] == [("old.csv", None)]
        assert store.measurements()["deviation"].tolist() == [0.02]
    capsys.readouterr()
    assert main(["history", "show", "--db", str(seen / "h.db"), "--machine", "M1"]) == 0
    assert "4 report(s)" in capsys.readouterr().out
    assert main(["history", "import", "--db", str(seen / "h.db"), "--machine", "M1", str(REPORTS[4])]) == 1
    err = capsys.readouterr().err
    assert [x for x in err.splitlines() if x.startswith("error:")] == [
        f"error: {seen / 'h.db'}: the history store cannot be written (read-only file, folder or file system) "
        "(SQLite writes the file and a -wal and -shm file beside it: allow writing both)"
    ] or ("cannot be written" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1), err
    assert digest(seen) == before


def source_cases(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Sources a copy must refuse, and the words of the refusal."""
    good = tmp_path / "good.db"
    with open_store(good, machine="M1") as store:
        import_history(store, ImportRequest(tuple(REPORTS[:2])))
    cases: dict[str, tuple[Path, str]] = {}
    empty = tmp_path / "empty.db"
    empty.write_bytes(b"")
    cases["empty"] = (empty, "not a setupfix history store (an empty file)")
    cut = tmp_path / "cut.db"
    cut.write_bytes(good.read_bytes()[:5000])
    cases["cut"] = (cut, "damaged")
    noise = tmp_path / "noise.db"
    noise.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 20)
    cases["noise"] = (noise, "damaged")
    for name, sql, words in (
        ("latin1", "UPDATE report SET name = CAST(x'6379636c65ff2e637376' AS TEXT) WHERE id = 2", "not UTF-8"),
        ("no_temperature", "DROP TABLE temperature", "no table temperature"),
    ):
        path = tmp_path / f"{name}.db"
        path.write_bytes(good.read_bytes())
        con = sqlite3.connect(path, isolation_level=None)
        con.execute(sql)
        con.close()
        cases[name] = (path, words)
    return cases


def test_a_copy_refuses_a_damaged_empty_or_incomplete_source_and_never_changes_it(tmp_path: Path) -> None:
    for name, (source, words) in source_cases(tmp_path).items():
        before = digest(tmp_path)
        target = tmp_path / f"target_{name}.db"
        with pytest.raises(StoreError) as caught, open_store(source, read_only=True) as src, open_store(target) as dst:
            migrate_history(src, dst)
        assert words in str(caught.value) and str(source) in str(caught.value), (name, caught.value)
        (tmp_path / f"target_{name}.db").unlink(missing_ok=True)
        assert digest(tmp_path) == before, name


@pytest.mark.parametrize("name", ["latin1", "no_temperature"])
def test_history_migrate_of_a_damaged_source_names_the_source_in_one_line(
    tmp_path: Path, name: str, location: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Through the door as it opens the source today, into a file or a server: a failure while the source's
    rows are read names the source (not the target), in one line, and the target keeps nothing."""
    source, _ = source_cases(tmp_path)[name]
    capsys.readouterr()
    assert main(["history", "migrate", "--from", str(source), "--db", location]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err
    lines = [x for x in err.splitlines() if x.startswith("error:")]
    assert len(lines) == 1 and lines[0].startswith(f"error: {source}:"), err
    with open_store(location) as store:
        assert store.count("report") == 0 and store.count("measurement") == 0


def test_a_v3_source_is_read_through_a_copy_and_stays_v3(tmp_path: Path) -> None:
    source = tmp_path / "v3.db"
    con = sqlite3.connect(source, isolation_level=None)
    migrate(con, str(source), upto=3)
    con.execute("INSERT INTO report VALUES (1, ?, 'c1.csv', 'canonical', 10, '2026-01-01T00:00:00')", ("c" * 64,))
    con.execute("INSERT INTO measurement (report_id, row, characteristic, deviation) VALUES (1, 0, 'D1', 0.03)")
    con.execute("INSERT INTO batch_claim (report_sha256, done) VALUES (?, 1)", ("c" * 64,))
    con.close()
    before = hashlib.sha256(source.read_bytes()).hexdigest()
    target = tmp_path / "new.db"
    with open_store(source, read_only=True) as src, open_store(target) as dst:
        copied = migrate_history(src, dst)
        with pytest.raises(StoreError, match="cannot be written"):
            src.add_corrections(dst.corrections())
    assert copied["report"] == copied["measurement"] == copied["batch_claim"] == 1
    assert hashlib.sha256(source.read_bytes()).hexdigest() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.db", "v3.db"]
    con = sqlite3.connect(f"file:{source}?mode=ro", uri=True)
    assert version_of(con) == 3
    con.close()
    with open_store(target) as store:
        assert store.measurements()["deviation"].tolist() == [0.03]
        assert version_of(store.db) == SCHEMA_VERSION  # type: ignore[attr-defined]
        assert next(iter(store.dump("batch_claim")))[:3] == ("default", "c" * 64, 1)


def test_a_server_store_opened_read_only_is_read_and_never_written(location: str) -> None:
    """On both back ends: ``read_only`` reads what is there and refuses every write in one StoreError."""
    with open_store(location, machine="M1") as store:
        import_history(store, ImportRequest(tuple(REPORTS[:2])))
    with open_store(location, machine="M1", read_only=True) as store:
        assert [r.name for r, _ in report_tables(store)] == [p.name for p in REPORTS[:2]]
        for write in (
            lambda: import_history(store, ImportRequest((REPORTS[2],))),
            lambda: store.add_corrections(store.corrections()),
        ):
            with pytest.raises(StoreError, match="cannot be written"):
                write()
    with open_store(location, machine="M1") as store:
        assert len(store.reports()) == 2
