"""parsers.read_report: read once (files, pipes, stdin), notes as data, no option ignored."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import pytest

import parsers
from parsers.source import MAX_REPORT_BYTES, Source
from setupfix.core.errors import ParameterError, ParseError

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_reports"
DMIS_NO_UNITS = (
    b"F(P)=FEAT/POINT,CART,1,0,0,0,0,1\nFA(P)=FEAT/POINT,CART,1.5,0,0,0,0,1\n"
    b"TA(P_X)=TOL/CORTOL,XAXIS,0.5,OUTOL\nENDFIL\n"
)
DMIS_INCH = b"UNITS/INCH,ANGDEC\n" + DMIS_NO_UNITS


def test_notes_come_back_as_data_not_warnings() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warnings.warn would fail the test
        result = parsers.read_report(Source("r.dmo", DMIS_NO_UNITS))
    assert result.format == "dmis" and result.source == "r.dmo"
    [note] = result.notes
    assert note.location is not None
    assert "no UNITS statement" in note.message and note.location.path == "r.dmo" and note.kind == "unit"


def test_notes_of_reads_in_threads_stay_apart() -> None:
    results: dict[int, parsers.ReadResult] = {}

    def work(i: int) -> None:
        data = DMIS_NO_UNITS if i % 2 else DMIS_INCH
        results[i] = parsers.read_report(Source(f"r{i}.dmo", data))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i, result in results.items():
        assert [n.location.path if n.location else None for n in result.notes] == ([f"r{i}.dmo"] if i % 2 else [])


def test_an_option_the_reader_does_not_use_is_refused() -> None:
    qif = SAMPLES / "qif" / os.listdir(SAMPLES / "qif")[0] if (SAMPLES / "qif").is_dir() else None
    with pytest.raises(ParameterError, match="the canonical reader does not use --columns"):
        parsers.read_report(SAMPLES / "guide_pins" / "cycle_01.csv", format="canonical", columns="actual=x")
    if qif is not None and qif.suffix.lower() == ".qif":
        with pytest.raises(ParameterError, match="the qif reader does not use --encoding"):
            parsers.read_report(qif, encoding="cp1252")
    with pytest.raises(ParameterError, match="unknown option 'sheet'"):
        parsers.read_report(SAMPLES / "guide_pins" / "cycle_01.csv", sheet="x")


def test_legacy_read_still_returns_the_table() -> None:
    with pytest.warns(Warning, match="no UNITS"):
        table = parsers.read(_write(DMIS_NO_UNITS))
    assert table["actual"].tolist() == [1.5]


def _write(data: bytes) -> Path:
    import tempfile

    fd, name = tempfile.mkstemp(suffix=".dmo")
    os.write(fd, data)
    os.close(fd)
    return Path(name)


def test_size_limit_is_one_reader_for_all(monkeypatch: pytest.MonkeyPatch) -> None:
    from parsers import source as _source

    monkeypatch.setattr(_source, "MAX_REPORT_BYTES", 100)
    big = _write(b"characteristic,nominal,actual\n" + b"D1,1.0,1.0\n" * 20)
    with pytest.raises(ParseError, match="larger than"):
        parsers.read_report(big, format="canonical")
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(b"x" * 200)))
    with pytest.raises(ParseError, match="larger than"):
        parsers.read_report("-")


@pytest.mark.slow
def test_stdin_and_pipes_keep_their_first_bytes(tmp_path: Path) -> None:
    # Over 8 KiB: a sniff then a second open of a pipe would lose UNITS/INCH (issue 10).
    body = b"".join(
        b"F(P%d)=FEAT/POINT,CART,1,0,0,0,0,1\nFA(P%d)=FEAT/POINT,CART,1.5,0,0,0,0,1\n"
        b"TA(P%d_X)=TOL/CORTOL,XAXIS,0.5,OUTOL\n" % (i, i, i)
        for i in range(120)
    )
    data = b"UNITS/INCH,ANGDEC\n" + body + b"ENDFIL\n"
    assert len(data) > 8192
    report = tmp_path / "r.dmo"
    report.write_bytes(data)
    for args, stdin in ((["-"], data), (["/dev/stdin"], data)):
        out = subprocess.run(
            [sys.executable, "-m", "setupfix", "parse", *args, "--out", "-"],
            input=stdin,
            capture_output=True,
            cwd=ROOT,
            timeout=60,
        )
        assert out.returncode == 0, out.stderr.decode()
        lines = out.stdout.decode().splitlines()
        assert lines[1].split(",")[1:3] == ["25.4", "38.1"], lines  # nominal and actual in mm from inch
    assert MAX_REPORT_BYTES == 256 * 2**20


def test_verdict_contradicting_the_numbers_is_a_note() -> None:
    data = (
        b"characteristic,nominal,actual,lower,upper,status\n"
        b"D1,10,14.4,-0.254,0.254,PASS\nD2,10,10.01,-0.254,0.254,PASS\nD3,10,10.0,-0.254,0.254,FAIL\n"
    )
    [note] = [n for n in parsers.read_report(Source("box.csv", data)).notes if n.kind == "verdict"]
    assert (
        note.location is not None
        and note.location.line == 2
        and note.message.startswith("2 row(s) whose own verdict contradicts")
    )
    assert "D1 says PASS at deviation +4.4 mm" in note.message and "D3 says FAIL" in note.message
    assert "D2" not in note.message


def test_lengths_carry_no_binary_noise() -> None:
    data = (
        b"UNITS/INCH,ANGDEC\nF(P)=FEAT/POINT,CART,1,0,0,0,0,1\nFA(P)=FEAT/POINT,CART,1.0001,0,0,0,0,1\n"
        b"TA(P_X)=TOL/CORTOL,XAXIS,0.0001,INTOL\nENDFIL\n"
    )
    row = parsers.read_report(Source("r.dmo", data)).table.iloc[0]
    assert (row["nominal"], row["actual"], row["deviation"]) == (25.4, 25.40254, 0.00254)
