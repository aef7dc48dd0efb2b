"""``parse -o`` works as ``model init -o`` does (issue 37 item 17): the same file as ``--out``, written
atomically, nothing left when every report fails."""

from __future__ import annotations

from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.cli.exit_codes import ERROR, OK

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"


@pytest.mark.parametrize("report", ["cycle_02.csv", "cycle_01.qif", "cycle_01.dmo"])
def test_short_o_writes_what_out_writes(tmp_path: Path, capsys: pytest.CaptureFixture[str], report: str) -> None:
    short, long = tmp_path / "short.csv", tmp_path / "long.csv"
    assert main(["parse", "-o", str(short), str(GUIDE / report)]) == OK
    assert main(["parse", str(GUIDE / report), "--out", str(long)]) == OK
    assert short.read_bytes() == long.read_bytes() and short.stat().st_size > 0
    assert main(["parse", str(GUIDE / report), "-o", "-"]) == OK
    out = capsys.readouterr().out
    assert out.encode() == short.read_bytes()


def test_short_o_writes_nothing_when_every_report_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("characteristic,nominal,actual\nA,1,x\n")
    target = tmp_path / "out.csv"
    assert main(["parse", "-o", str(target), str(bad)]) == ERROR
    assert not target.exists() and list(tmp_path.iterdir()) == [bad]
    assert "bad.csv" in capsys.readouterr().err
