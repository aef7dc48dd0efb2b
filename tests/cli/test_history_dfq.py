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
