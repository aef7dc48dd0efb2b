"""Issue 21 item 9: a damaged, read-only, locked or full store, and a full disk under any output.

Each ends in one line naming the file, a non-zero exit and nothing half-written -- never
"internal error".  Real files and processes: garbage bytes, a damaged page, an immutable
(root) or mode-0444 file, a folder that cannot be written, another process holding the
write lock, a file size limit (``RLIMIT_FSIZE``: the kernel refuses the write as a full
disk would), SQLite's own page limit.  And a store created by several processes at once,
or killed while it is created, is a store.
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from setupfix.cli import main
from setupfix.cli.exit_codes import ERROR
from setupfix.store import open_store

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
MODEL = GUIDE / "model.toml"
REPORTS = sorted(GUIDE.glob("cycle_0*.csv"))
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def one_line(err: str, name: str) -> str:
    """The one error line of a failed command: it names ``name``; no traceback, no internal error."""
    assert "internal error" not in err and "Traceback" not in err, err
    lines = [x for x in err.splitlines() if x.startswith("error:")]
    assert len(lines) == 1 and name in lines[0], err
    return lines[0]


def store_of(tmp_path: Path, name: str = "h.db", reports: list[Path] = REPORTS[:2]) -> Path:
    db = tmp_path / name
    assert main(["history", "import", "--db", str(db), *map(str, reports)]) == 0
    return db


def counts(db: Path) -> tuple[int, int]:
    with open_store(db) as store:
        return len(store.reports()), len(store.recommendations())


def folder(tmp_path: Path) -> Path:
    d = tmp_path / "reports"
    d.mkdir()
    for r in REPORTS[2:4]:
        shutil.copy(r, d / r.name)
    return d


#: The commands that take a store, with the store's path as {db} and a folder of reports as {dir}.
COMMANDS = {
    "show": ["history", "show", "--db", "{db}"],
    "import": ["history", "import", "--db", "{db}", str(REPORTS[4])],
    "export": ["history", "export", "measurements", "--db", "{db}", "--out", "{out}"],
    "batch": ["batch", "{dir}", "--model", str(MODEL), "--out", "{out}", "--store", "{db}", "--settle", "0"],
    "correct": ["correct", "--model", "{ewma}", "--store", "{db}", str(REPORTS[4]), "--offsets", "{out}"],
    "diagnose": ["diagnose", "--db", "{db}", "--model", str(MODEL), "--no-walk"],
}


def ewma_model(tmp_path: Path) -> Path:
    """The guide-pin model smoothing over the store (``correct --store`` reads it only then)."""
    path = tmp_path / "ewma.toml"
    path.write_text(MODEL.read_text() + "\n[safety]\newma = 0.5\n")
    return path


def run(name: str, db: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    out = tmp_path / f"{name}.out.csv"
    d = tmp_path / "reports" if (tmp_path / "reports").is_dir() else folder(tmp_path)
    capsys.readouterr()
    argv = [a.format(db=db, out=out, dir=d, ewma=ewma_model(tmp_path)) for a in COMMANDS[name]]
    assert main(argv) == ERROR
    assert not out.exists()  # nothing half-written
    return one_line(capsys.readouterr().err, db.name)


# -- damaged -------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("damage", ["garbage", "page"])
def test_a_damaged_store_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str, damage: str
) -> None:
    db = store_of(tmp_path, reports=REPORTS[:3])
    data = bytearray(db.read_bytes())
    if damage == "garbage":
        data = bytearray(os.urandom(len(data)))
    else:  # the report table's page: the header reads, the rows do not
        with contextlib.closing(sqlite3.connect(db)) as con:
            page = con.execute("SELECT rootpage FROM sqlite_master WHERE name = 'report'").fetchone()[0]
        size = 4096
        for i in range((page - 1) * size + 8, page * size):
            data[i] = (data[i] * 7 + 3) % 256
    db.write_bytes(bytes(data))
    line = run(command, db, tmp_path, capsys)
    assert "damaged" in line


# -- read-only -----------------------------------------------------------------------------------


@contextlib.contextmanager
def read_only(path: Path) -> Iterator[None]:
    """``path`` made unwritable for this process: mode 0444/0555, or as root the immutable flag."""
    if os.geteuid() != 0:
        mode = path.stat().st_mode
        path.chmod(mode & ~0o222)
        try:
            yield
        finally:
            path.chmod(mode)
        return
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(path)], capture_output=True).returncode:
        pytest.skip("root, and this file system has no immutable flag: nothing is read-only to root")
    try:
        yield
    finally:
        subprocess.run(["chattr", "-i", str(path)], check=True)


@pytest.mark.parametrize("command", ["import", "batch", "diagnose"])
def test_a_read_only_store_file_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    db = store_of(tmp_path)
    before = counts(db)
    with read_only(db):
        line = run(command, db, tmp_path, capsys)
    assert "read-only" in line or "cannot be opened" in line
    assert counts(db) == before


@pytest.mark.parametrize("existing", [True, False])
def test_a_store_in_a_read_only_folder_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], existing: bool
) -> None:
    where = tmp_path / "ro"
    where.mkdir()
    db = store_of(where) if existing else where / "new.db"
    with read_only(where):
        line = run("import", db, tmp_path, capsys)
    assert "read-only" in line or "cannot be opened or created" in line
    assert existing or not db.exists()


# -- locked --------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("command", ["import", "batch", "diagnose", "correct"])
def test_a_store_locked_beyond_the_busy_timeout_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, command: str
) -> None:
    import setupfix.store.sqlite as sqlite_store

    db = store_of(tmp_path)
    before = counts(db)
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sqlite3, sys, time\n"
            f"c = sqlite3.connect({str(db)!r}, isolation_level=None)\n"
            "c.execute('BEGIN IMMEDIATE'); c.execute('CREATE TABLE held (x)')\n"
            "print('held', flush=True); sys.stdin.read()",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "held"  # type: ignore[union-attr]
        monkeypatch.setattr(sqlite_store, "BUSY_TIMEOUT_S", 0.5)
        if command == "correct":
            # correct --store records its recommendation (the audit trail): it refuses in one line and writes no
            # offsets when the store cannot take the record
            out = tmp_path / "c.csv"
            argv = [a.format(db=db, out=out, dir="", ewma=ewma_model(tmp_path)) for a in COMMANDS["correct"]]
            assert main(argv) == 1 and not out.exists()
            line = capsys.readouterr().err.strip()
            assert len(line.splitlines()) == 1 and str(db) in line
        else:
            line = run(command, db, tmp_path, capsys)
        assert "locked by another process" in line
    finally:
        holder.communicate("")
    assert counts(db) == before


# -- full ----------------------------------------------------------------------------------------


def _limited(limit: int) -> Callable[[], None]:
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write fails with EFBIG instead of killing

    return apply


def cli(
    args: Sequence[str | Path], *, limit: int | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "setupfix", *map(str, args)],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=cwd,
        preexec_fn=_limited(limit) if limit is not None else None,
    )


def many_reports(d: Path, n: int) -> Path:
    d.mkdir(exist_ok=True)
    for k in range(n):
        src = REPORTS[k % 5]
        (d / f"r{k:03d}.csv").write_text(src.read_text().replace(f"cycle 0{k % 5 + 1}", f"part {k:03d}"))
    return d


@pytest.mark.slow
@pytest.mark.parametrize("command", ["import", "batch"])
def test_a_full_store_is_one_line_naming_it_and_keeps_what_it_held(tmp_path: Path, command: str) -> None:
    db = store_of(tmp_path)
    before = counts(db)
    d = many_reports(tmp_path / "many", 40)
    limit = max(db.stat().st_size, 32768) + 8192  # room for the -shm index, not for 40 reports
    args: list[str | Path] = (
        ["history", "import", "--db", db, d]
        if command == "import"
        else ["batch", d, "--model", MODEL, "--out", tmp_path / "o.csv", "--store", db, "--settle", "0"]
    )
    r = cli(args, limit=limit)
    assert r.returncode != 0
    line = one_line(r.stderr, db.name)
    assert "disk" in line
    assert not (tmp_path / "o.csv").exists()
    if command == "import":  # one transaction: all or nothing
        assert counts(db) == before
        return
    # batch: a report is stored whole as it is done, but none counts as processed (the output was not
    # written): the next run corrects all of them, taking over the claims the failed run could not free
    # (how many fit before the disk filled depends on the file sizes: the message says, and each is whole)
    stored = counts(db)[0] - before[0]
    assert counts(db)[1] - before[1] == stored and stored < 40
    assert f"{stored} report(s) of this run were stored, each with its recommendations, none marked processed" in line
    again = cli(["batch", d, "--model", MODEL, "--out", tmp_path / "o.csv", "--store", db, "--settle", "0", "--json"])
    assert again.returncode == 0, again.stderr
    assert '"reports": 40' in again.stdout and counts(db) == (42, 40 + stored)


def test_sqlite_s_own_full_is_one_line_naming_the_store(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """SQLITE_FULL (the page limit here, a full disk in the field) through the CLI."""
    import setupfix.store.sqlite as sqlite_store

    db = store_of(tmp_path)
    before = counts(db)
    real = sqlite_store.SQLiteStore.__init__

    def capped(self: sqlite_store.SQLiteStore, path: str, **handle: Any) -> None:
        real(self, path, **handle)
        pages = self.db.execute("PRAGMA page_count").fetchone()[0]
        self.db.execute(f"PRAGMA max_page_count = {pages}")

    monkeypatch.setattr(sqlite_store.SQLiteStore, "__init__", capped)
    many_reports(tmp_path / "many", 20)
    capsys.readouterr()
    assert main(["history", "import", "--db", str(db), str(tmp_path / "many")]) == ERROR
    assert "disk is full" in one_line(capsys.readouterr().err, db.name)
    monkeypatch.undo()
    assert counts(db) == before


#: command, the file it writes, the file size limit (bytes): below the output, above what it writes before
#: (the store's 32 KiB -shm index for ``history export``).
OUTPUTS: dict[str, tuple[list[str | Path], str, int]] = {
    "offsets CSV (correct)": (["correct", "--model", MODEL, REPORTS[0], "--offsets", "{t}/old.csv"], "old.csv", 64),
    "program (correct)": (
        ["correct", "--model", MODEL, REPORTS[0], "--offsets", "{t}/old.nc", "--controller", "fanuc"],
        "old.nc",
        64,
    ),
    "offsets CSV (batch)": (
        ["batch", "{t}/many", "--model", MODEL, "--out", "{t}/old.csv", "--settle", "0"],
        "old.csv",
        64,
    ),
    "program (batch)": (
        ["batch", "{t}/many", "--model", MODEL, "--out", "{t}/progs", "--settle", "0", "--controller", "fanuc"],
        "progs/r000.csv.nc",
        64,
    ),
    "export CSV": (["history", "export", "measurements", "--db", "{t}/h.db", "--out", "{t}/old.csv"], "old.csv", 36000),
    "CSV and JSON (simulate)": (
        ["simulate", "--model", MODEL, "--out", "{t}/sim", "--cycles", "30"],
        "sim/measurements.csv",
        64,
    ),
}


@pytest.mark.slow
@pytest.mark.parametrize("what", sorted(OUTPUTS))
def test_a_full_disk_under_any_output_is_one_line_naming_it_and_the_old_file_stays(tmp_path: Path, what: str) -> None:
    many_reports(tmp_path / "many", 60)
    db = tmp_path / "h.db"
    assert main(["history", "import", "--db", str(db), str(tmp_path / "many")]) == 0
    (tmp_path / "sim").mkdir()
    (tmp_path / "progs").mkdir()
    args, target, limit = OUTPUTS[what]
    argv = [str(a).format(t=tmp_path) for a in args]
    old = tmp_path / target
    if what == "program (batch)":  # a program set setupfix wrote before (a foreign file is refused unwritten)
        assert cli(argv).returncode == 0
    else:
        old.write_text("old\n")
    before = old.read_text()
    r = cli(argv, limit=limit)
    assert r.returncode != 0
    assert "cannot write" in one_line(r.stderr, Path(target).name)
    assert old.read_text() == before
    assert not [p for p in tmp_path.rglob("*.tmp")]


# -- creation ------------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_store_created_by_many_processes_at_once_is_a_store(tmp_path: Path) -> None:
    for round_ in range(3):
        db = tmp_path / f"new{round_}.db"
        start = time.time() + 1.5
        code = (
            "import sys, time\nfrom setupfix.store import open_store\n"
            f"time.sleep(max(0.0, {start} - time.time()))\n"
            f"with open_store({str(db)!r}) as s:\n    print(len(s.reports()))\n"
        )
        procs = [
            subprocess.Popen(
                [sys.executable, "-c", code], env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            for _ in range(6)
        ]
        results = [p.communicate(timeout=120) for p in procs]
        assert [p.returncode for p in procs] == [0] * 6, [err for _, err in results]
        assert counts(db) == (0, 0)


@pytest.mark.slow
def test_a_store_killed_while_it_is_created_is_created_by_the_next_open(tmp_path: Path) -> None:
    db = tmp_path / "killed.db"
    code = (
        "import os, signal\nimport setupfix.store.schema as s\n"
        "def die(db):\n    os.kill(os.getpid(), signal.SIGKILL)\n"
        "s.MIGRATIONS = (s.MIGRATIONS[0], die, *s.MIGRATIONS[2:])\n"
        "from setupfix.store import open_store\n"
        f"open_store({str(db)!r})\n"
    )
    r = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True)
    assert r.returncode == -signal.SIGKILL and db.exists()
    assert main(["history", "import", "--db", str(db), str(REPORTS[0])]) == 0
    assert counts(db) == (1, 0)


@pytest.mark.parametrize("left", ["empty file", "version table only"])
def test_what_a_killed_creation_left_is_completed(tmp_path: Path, left: str) -> None:
    """An empty file, and what setupfix before this fix left when killed between its two first commits."""
    db = tmp_path / "h.db"
    db.write_bytes(b"")
    if left == "version table only":
        with contextlib.closing(sqlite3.connect(db)) as con:
            con.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
            con.execute("INSERT INTO schema_version VALUES (0)")
            con.commit()
    assert main(["history", "import", "--db", str(db), str(REPORTS[0])]) == 0
    assert counts(db) == (1, 0)


@contextlib.contextmanager
def tiny_disk(where: Path, size: str = "512k") -> Iterator[Path]:
    """A real small file system (tmpfs) at ``where`` -- root only, where mounting is allowed; else skipped."""
    where.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small file system needs root")
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], capture_output=True)
    if made.returncode:
        pytest.skip("this system does not allow mounting a tmpfs")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def _fill(disk: Path, leave: int) -> None:
    """Fill ``disk`` until about ``leave`` bytes are free."""
    free = shutil.disk_usage(disk).free
    with open(disk / "filler", "wb") as f:
        f.write(b"\0" * max(0, free - leave))


def test_a_full_disk_under_the_store_and_under_an_output_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ENOSPC from a real file system: the store keeps what it held, the old output stays, no temporary file."""
    with tiny_disk(tmp_path / "disk") as disk:
        db = store_of(disk)
        before = counts(db)
        _fill(disk, 8192)
        many_reports(tmp_path / "many", 40)
        capsys.readouterr()
        assert main(["history", "import", "--db", str(db), str(tmp_path / "many")]) == ERROR
        line = one_line(capsys.readouterr().err, db.name)
        assert "disk" in line
        (disk / "filler").unlink()  # (reading a WAL store needs room for its -shm index too)
        assert counts(db) == before
        old = disk / "offsets.csv"
        old.write_text("old\n")
        _fill(disk, 0)
        assert main(["correct", "--model", str(MODEL), str(REPORTS[0]), "--offsets", str(old)]) == ERROR
        line = one_line(capsys.readouterr().err, old.name)
        assert "cannot write" in line and "No space left" in line
        assert old.read_text() == "old\n" and not list(disk.glob("*.tmp"))
