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

from parsers.current import read_current
from setupfix.correction.offsets import offset_rows
from setupfix.model import load_model
from setupfix.outputs.controllers import render

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


def test_rs274_reports_a_block_it_refuses(tmp_path: Path) -> None:
    # the harness sees rs274's errors: a Fanuc radius block (L12) is one rs274 does not know
    with pytest.raises(AssertionError, match=r"(?s)rs274 refused the program: .*G10 L12 P5"):
        run_rs274("G21\nG90 G10 L12 P5 R+1.000\nM30\n", tmp_path)


@pytest.mark.parametrize("name", ["fanuc", "haas"])
def test_multi_axis_set_program_holds_current_plus_change_on_every_axis(tmp_path: Path, name: str) -> None:
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


def test_whatever_was_there_the_set_program_leaves_current_plus_change(tmp_path: Path) -> None:
    # rs274 starts from other offsets (parameter file, inches): absolute blocks overwrite them all
    program = render("fanuc", fixture_rows("fanuc", "set", rotation=0.0, wks_only=True))
    before = {5221 + 20 * (p - 1) + i: 3.0 + p + i for p in (1, 2) for i in range(3)}
    got = read_back(linuxcnc_text(program), tmp_path, [(1, "X"), (1, "Z"), (2, "Y")], parameters=before)
    assert got == pytest.approx({(1, "X"): -250.111, (1, "Z"): -412.552, (2, "Y"): -0.496}, abs=5e-4)
    # and a parameter the program does not write keeps its value (the read-back reads what is there)
    untouched = read_back("%\nG21\nM30\n%\n", tmp_path, [(3, "Z")], parameters={5263: 2.0})
    assert untouched[(3, "Z")] == pytest.approx(50.8)


def test_the_one_axis_sample_program_reads_back(tmp_path: Path) -> None:
    model = load_model(SAMPLE / "model.toml")
    current = read_current(SAMPLE / "current.csv", model)
    rows = offset_rows(model, {"W1": -0.022, "W2": 0.022, "T5": -0.008, "T12": 0.002}, current=current)
    program = render("fanuc", rows, "report.csv cycle 7")
    got = read_back(linuxcnc_text(program), tmp_path, [(1, "Z"), (2, "Z")])
    assert got == pytest.approx({(1, "Z"): -412.552, (2, "Z"): -412.465}, abs=5e-4)


def test_an_inch_program_reads_back_in_inches(tmp_path: Path) -> None:
    rows = [
        row("W1.X", "G54", "wks", "X", 0.0004, 1.2345, unit="inch", resolution=0.0001),
        row("W1.Y", "G54", "wks", "Y", -0.0012, -3.0, unit="inch", resolution=0.0001),
        row("W1.Z", "G54", "wks", "Z", 0.0, -16.2422, unit="inch", resolution=0.0001),
    ]
    program = render("haas", rows)
    assert "\nG20\n" in program
    got = read_back(program, tmp_path, [(1, "X"), (1, "Y"), (1, "Z")], inch=True)
    assert got == pytest.approx({(1, "X"): 1.2349, (1, "Y"): -3.0012, (1, "Z"): -16.2422}, abs=5e-5)


XYZ = ROOT / "sample_reports" / "two_station_xyz"
XYZ_CURRENT = (
    "register,axis,value\nG54,X,-250.123\nG54,Y,120.5\nG54,Z,-412.53\nG55,X,50.0\nG55,Y,-0.5\n"
    "G55,Z,-412.487\nH1,,-0.012\nD1,,0.002\nH2,,0.0\n"
)


@pytest.mark.slow
def test_the_two_station_sample_from_report_to_read_back(tmp_path: Path) -> None:
    """The whole door: a multi-axis report corrected, the Fanuc program written, read back on every axis."""
    if not (XYZ / "model.toml").exists():
        pytest.skip("sample_reports/two_station_xyz arrives with the multi-axis model loader (issue 23, axes part)")
    import tomllib

    from setupfix.core.errors import ExportError
    from setupfix.model import model_from_dict
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.export import export
    from setupfix.usecases.requests import CorrectRequest, CurrentOffsets

    doc = tomllib.loads((XYZ / "model.toml").read_text(encoding="utf-8"))
    with_rotation = model_from_dict(doc)
    (tmp_path / "c.csv").write_text(XYZ_CURRENT + "G54,C,0\nG55,C,0.01\n")
    request = CorrectRequest(with_rotation, current=CurrentOffsets.read(tmp_path / "c.csv", with_rotation))
    cycles = correct_report(request, XYZ / "cycle_01.csv").cycles
    if any(c.corrections.get("W1.C") or c.corrections.get("W2.C") for c in cycles):
        with pytest.raises(
            ExportError,
            match=r"fanuc: cannot express register 'G5[45]' \(W[12]\.C\): G10 L2 holds "
            "no rotation",
        ):
            export(cycles, str(tmp_path / "r.nc"), controller="fanuc", current=request.current)
        assert not (tmp_path / "r.nc").exists()
    doc["process"]["rotation"] = False  # a fixture without the rotation: the Fanuc program holds it all
    model = model_from_dict(doc)
    (tmp_path / "c.csv").write_text(XYZ_CURRENT)
    request = CorrectRequest(model, current=CurrentOffsets.read(tmp_path / "c.csv", model))
    (cycle,) = correct_report(request, XYZ / "cycle_01.csv").cycles
    done = export([cycle], str(tmp_path / "p.nc"), controller="fanuc", current=request.current, program_number=4321)
    assert done.text.startswith("%\nO4321 (")
    got = read_back(linuxcnc_text(done.text), tmp_path, [(p, a) for p in (1, 2) for a in "XYZ"])
    for (p, axis), value in got.items():
        cid = f"W{p}.{axis}"
        assert request.current is not None
        want = request.current[cid] + cycle.corrections.get(cid, 0.0)
        assert round(value, 3) == round(want, 3), cid
    tools = run_g10(done.text)
    assert tools[(11, 1, "R")] == pytest.approx(-0.012 + cycle.corrections.get("T1", 0.0), abs=5e-4)
    assert tools[(13, 1, "R")] == pytest.approx(0.002 + cycle.corrections.get("T1.R", 0.0), abs=5e-4)
