"""``history export dfq``: the stored measurements as a DFQ file that reads back through the Q-DAS reader."""

from __future__ import annotations

from pathlib import Path

import pytest
from spc_examples import closed_loop_store

import parsers
from setupfix.cli import main


def test_export_dfq_reads_back_every_value(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "loop").mkdir()
    db = closed_loop_store(tmp_path / "loop")
    out = tmp_path / "loop.dfq"
    assert main(["history", "export", "dfq", "--db", str(db), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    n = int(err.split(" dfq row(s)")[0].split()[-1])
    table = parsers.read_report(out).table
    assert len(table) == n > 0
    assert main(["history", "export", "dfq", "--db", str(db), "--out", str(tmp_path / "no" / "x.dfq")]) != 0
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_export_dfq_of_names_with_unicode_spaces(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 37, item 17: a no-break space in a name aborted the whole export; now it reads back the same."""
    from conftest import GUIDE_PINS

    text = (GUIDE_PINS / "cycle_04.csv").read_text()
    report = tmp_path / "nbsp.csv"
    report.write_text(text.replace("P2 D3,", "P2\u00a0D3,").replace("cycle 04", "cycle\u202f04"), encoding="utf-8")
    db, out = tmp_path / "h.db", tmp_path / "h.dfq"
    assert main(["history", "import", "--db", str(db), str(report)]) == 0
    assert main(["history", "export", "dfq", "--db", str(db), "--out", str(out)]) == 0
    assert "error" not in capsys.readouterr().err
    table = parsers.read_report(out).table
    assert len(table) == len(text.splitlines()) - 1
    assert "P2\u00a0D3" in set(table["characteristic"]) and set(table["part"]) == {"cycle\u202f04"}
