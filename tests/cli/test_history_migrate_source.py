"""Issue 37 item 15 at the door: ``history migrate`` only reads its source. A 0-byte source is refused in one
line (it never turns into an empty store), and an older store is copied without being upgraded in place."""

from __future__ import annotations

import hashlib
import sqlite3
from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.store import open_store
from setupfix.store.schema import migrate, version_of


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_zero_byte_source_is_refused_and_stays_zero_bytes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "empty.db"
    source.write_bytes(b"")
    capsys.readouterr()
    assert main(["history", "migrate", "--from", str(source), "--db", str(tmp_path / "new.db")]) == 1
    err = capsys.readouterr().err
    assert [x for x in err.splitlines() if x.startswith("error:")] and "Traceback" not in err
    assert source.stat().st_size == 0


@pytest.mark.parametrize("version", [2, 3, 4])
def test_an_older_source_is_copied_and_left_as_it_was(
    version: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = tmp_path / "old.db"
    con = sqlite3.connect(source, isolation_level=None)
    migrate(con, str(source), upto=version)
    con.close()
    before = _sha(source)
    assert main(["history", "migrate", "--from", str(source), "--db", str(tmp_path / "new.db")]) == 0
    assert _sha(source) == before
    con = sqlite3.connect(f"file:{source}?mode=ro", uri=True)
    assert version_of(con) == version
    con.close()
    with open_store(tmp_path / "new.db") as store:
        assert store.count("report") == 0
