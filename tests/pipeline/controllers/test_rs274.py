"""The absolute (``G90 G10 L2``) programs read back through LinuxCNC's ``rs274``, an interpreter no one here wrote.

Each program runs in ``rs274`` (:mod:`rs274`: how it is fetched and run), with ``(debug, …)`` reads of the work
offsets appended; every axis of every ``G10 L2`` WKS must hold current + change to the register resolution.
``rs274`` reads ``G10 L20`` and ``G10 L10``–``L13`` as other things than Fanuc and Haas do (L20: offsets that
make the current position read the value; L10/L11: its tool table; L12/L13: errors) and sets on ``G91 G10 L2``:
those blocks are taken out of the text it runs and checked with the project's own interpreter (:mod:`g10`),
as are the incremental programs.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from g10 import run_g10
from multi_axis_rows import SPEC, fixture_rows, row
from rs274 import read_back, run_rs274
from setupfix.model import load_model
from setupfix.offsets import offset_rows
from parsers.current import read_current
from setupfix.pipeline.controllers import render

ROOT = Path(__file__).resolve().parents[3]
SAMPLE = ROOT / "sample_reports" / "controllers"
START = {cid: current for cid, _, _, _, current, _, _ in SPEC}
DELTA = {cid: delta for cid, _, _, delta, _, _, _ in SPEC}
FANUC_P = {"W1": 1, "W2": 2}
#: Blocks rs274 reads otherwise than Fanuc/Haas (checked by :func:`g10.run_g10` instead).
NOT_FOR_RS274 = re.compile(r"^G9[01] G10 L(?:1[0-3]|20) .*\n", re.M)


def linuxcnc_text(program: str) -> str:
    """``program`` without the blocks rs274 reads otherwise (at least one G10 L2 block stays)."""
    kept = NOT_FOR_RS274.sub("", program)
    assert re.search(r"^G90 G10 L2 ", kept, re.M)
    return kept


def test_rs274_reports_a_block_it_refuses(tmp_path):
    # the harness sees rs274's errors: a Fanuc radius block (L12) is one rs274 does not know
    with pytest.raises(AssertionError, match=r"(?s)rs274 refused the program: .*G10 L12 P5"):
        run_rs274("G21\nG90 G10 L12 P5 R+1.000\nM30\n", tmp_path)


@pytest.mark.parametrize("name", ["fanuc", "haas"])
def test_multi_axis_set_program_holds_current_plus_change_on_every_axis(tmp_path, name):
    program = render(name, fixture_rows(name, "set", rotation=0.0), "r.csv P1", program_number=4711)
    reads = [(FANUC_P[w], axis) for w in FANUC_P for axis in "XYZ"]
    got = read_back(linuxcnc_text(program), tmp_path, reads)
    for (p, axis), value in got.items():
        cid = f"W{p}.{axis}"
        assert value == pytest.approx(START[cid] + DELTA[cid], abs=0.0005), cid  # to the 0.001 mm resolution
        assert round(value, 3) == round(START[cid] + DELTA[cid], 3)
    # the blocks rs274 does not run: the project's interpreter
    state = run_g10(program)
    assert state[(20, 7, "X")] == pytest.approx(START["W3.X"] + DELTA["W3.X"])
    assert state[(13, 5, "R")] == pytest.approx(START["T5.R"] + DELTA["T5.R"])
    assert state[(10, 12, "R")] == pytest.approx(START["T12"] + DELTA["T12"])


def test_whatever_was_there_the_set_program_leaves_current_plus_change(tmp_path):
    # rs274 starts from other offsets (parameter file, inches): absolute blocks overwrite them all
    program = render("fanuc", fixture_rows("fanuc", "set", rotation=0.0, wks_only=True))
    before = {5221 + 20 * (p - 1) + i: 3.0 + p + i for p in (1, 2) for i in range(3)}
    got = read_back(linuxcnc_text(program), tmp_path, [(1, "X"), (1, "Z"), (2, "Y")], parameters=before)
    assert got == pytest.approx({(1, "X"): -250.111, (1, "Z"): -412.552, (2, "Y"): -0.496}, abs=5e-4)
    # and a parameter the program does not write keeps its value (the read-back reads what is there)
    untouched = read_back("%\nG21\nM30\n%\n", tmp_path, [(3, "Z")], parameters={5263: 2.0})
    assert untouched[(3, "Z")] == pytest.approx(50.8)


def test_the_one_axis_sample_program_reads_back(tmp_path):
    model = load_model(SAMPLE / "model.toml")
    current = read_current(SAMPLE / "current.csv", model)
    rows = offset_rows(model, {"W1": -0.022, "W2": 0.022, "T5": -0.008, "T12": 0.002}, current=current)
    program = render("fanuc", rows, "report.csv cycle 7")
    got = read_back(linuxcnc_text(program), tmp_path, [(1, "Z"), (2, "Z")])
    assert got == pytest.approx({(1, "Z"): -412.552, (2, "Z"): -412.465}, abs=5e-4)


def test_an_inch_program_reads_back_in_inches(tmp_path):
    rows = [row("W1.X", "G54", "wks", "X", 0.0004, 1.2345, unit="inch", resolution=0.0001),
            row("W1.Y", "G54", "wks", "Y", -0.0012, -3.0, unit="inch", resolution=0.0001),
            row("W1.Z", "G54", "wks", "Z", 0.0, -16.2422, unit="inch", resolution=0.0001)]
    program = render("haas", rows)
    assert "\nG20\n" in program
    got = read_back(program, tmp_path, [(1, "X"), (1, "Y"), (1, "Z")], inch=True)
    assert got == pytest.approx({(1, "X"): 1.2349, (1, "Y"): -3.0012, (1, "Z"): -16.2422}, abs=5e-5)
