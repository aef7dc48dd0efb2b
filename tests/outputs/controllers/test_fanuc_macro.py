"""Macro-variable programs (``fanuc-macro``, ``haas-macro``): the variable of every register kind against the
controls' tables, add and set modes, the guard, refusals; read back by LinuxCNC's ``rs274`` where it can
(:mod:`rs274`: G54…G59 are its own ``#5221…``, tools up to H200 plain parameters), the rest by a small
interpreter of the two assignment forms written here."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from multi_axis_rows import SPEC, fixture_rows, row
from rs274 import MAX_PARAMETER, linuxcnc_macro, read_back, read_parameters

from setupfix.core.errors import ExportError
from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.controllers import PROGRAM_SUFFIX, render
from setupfix.outputs.controllers.fanuc_macro import fanuc_variable, haas_variable

START = {cid: current for cid, _, _, _, current, _, _ in SPEC}
DELTA = {cid: delta for cid, _, _, delta, _, _, _ in SPEC}

# (register, kind, axis, offset) → variable, from the Fanuc memory C and Haas mill tables
FANUC = [
    ("G54", "wks", "X", "geometry", 5221),
    ("G55", "wks", "Z", "geometry", 5243),
    ("G59", "wks", "Y", "geometry", 5322),
    ("G54.1 P1", "wks", "X", "geometry", 7001),
    ("G54.1 P48", "wks", "Z", "geometry", 7943),
    ("G54.1 P49", "wks", "X", "geometry", 14961),
    ("G54.1 P300", "wks", "Z", "geometry", 19983),
    ("H5", "tool", "Z", "wear", 2005),
    ("H5", "tool", "Z", "geometry", 2205),
    ("H200", "tool", "Z", "geometry", 2400),
    ("H201", "tool", "Z", "wear", 10201),
    ("H999", "tool", "Z", "geometry", 11999),
    ("D5", "tool", "R", "wear", 12005),
    ("D12", "tool", "R", "geometry", 13012),
]
HAAS = [
    ("G54", "wks", "X", "geometry", 5221),
    ("G56", "wks", "Y", "geometry", 5262),
    ("G110", "wks", "X", "geometry", 7001),
    ("G129", "wks", "Z", "geometry", 7383),
    ("G154 P7", "wks", "Y", "geometry", 7122),
    ("G154 P20", "wks", "X", "geometry", 7381),
    ("H5", "tool", "Z", "geometry", 2005),
    ("H5", "tool", "Z", "wear", 2205),
    ("H200", "tool", "Z", "wear", 2400),
]


def one(register: str, kind: str, axis: str, offset: str = "geometry", delta: float = 0.01) -> OffsetRow:
    cid = "W1." + axis if kind == "wks" else ("T1.R" if axis == "R" else "T1")
    return row(cid, register, kind, axis, delta, offset=offset)


@pytest.mark.parametrize(("register", "kind", "axis", "offset", "variable"), FANUC)
def test_fanuc_variables(register: str, kind: str, axis: str, offset: str, variable: int) -> None:
    assert fanuc_variable(one(register, kind, axis, offset)) == variable


@pytest.mark.parametrize(("register", "kind", "axis", "offset", "variable"), HAAS)
def test_haas_variables(register: str, kind: str, axis: str, offset: str, variable: int) -> None:
    assert haas_variable(one(register, kind, axis, offset)) == variable


def test_a_tool_number_without_h_or_d_is_its_number() -> None:
    r = row("T7", "T7", "tool", "Z", 0.01, number=7, offset="wear")
    assert fanuc_variable(r) == 2007


@pytest.mark.parametrize(
    ("controller", "bad", "why"),
    [
        ("fanuc-macro", one("G54", "wks", "X", "wear"), "no wear variable"),
        ("fanuc-macro", one("G54", "wks", "A"), "only X, Y and Z"),
        ("fanuc-macro", one("G54.1 P301", "wks", "X"), r"G54.1 P 301 does not exist"),
        ("fanuc-macro", one("G110", "wks", "X"), "a work offset is G54"),
        ("fanuc-macro", one("H1000", "tool", "Z"), "offset number 1000 does not exist"),
        ("fanuc-macro", one("D5", "tool", "Z"), "a tool length is an H register"),
        ("fanuc-macro", one("H5", "tool", "R"), "a tool radius is a D register"),
        ("haas-macro", one("G154 P21", "wks", "X"), "P1…P20"),
        ("haas-macro", one("G54.1 P1", "wks", "X"), "a work offset is G54"),
        ("haas-macro", one("D5", "tool", "R"), "diameter or a radius"),
        ("haas-macro", one("H201", "tool", "Z"), "offset number 201 does not exist"),
        ("fanuc-macro", one("G54", "wks", "C", delta=0.015), "no macro variable holds a work offset rotation"),
    ],
)
def test_refusals_name_the_register(controller: str, bad: OffsetRow, why: str) -> None:
    with pytest.raises(ExportError, match=why) as err:
        render(controller, [bad])
    assert repr(bad.register) in str(err.value)


def test_two_registers_on_one_variable_are_refused() -> None:
    rows = [one("H5", "tool", "Z", "wear"), row("T9", "T9", "tool", "Z", 0.01, number=5, offset="wear")]
    with pytest.raises(ExportError, match="both write #2005"):
        render("fanuc-macro", rows)


_SET = re.compile(r"^#(\d+)=(-?\d+\.\d+) \(")
_ADD = re.compile(r"^#(\d+)=\[#(\d+)([-+]\d+\.\d+)\] \(")


def run_assignments(program: str, state: dict[int, float]) -> dict[int, float]:
    """The variables after every assignment line of ``program`` (``#n=v``, ``#n=[#n±v]``), the guard ignored."""
    out = dict(state)
    for line in program.splitlines():
        if (m := _SET.match(line)) is not None:
            out[int(m.group(1))] = float(m.group(2))
        elif (m := _ADD.match(line)) is not None:
            assert m.group(1) == m.group(2), line
            out[int(m.group(1))] = out.get(int(m.group(1)), 0.0) + float(m.group(3))
        else:
            assert not line.startswith("#") or re.match(r"^#549=\d+$", line), line
    return out


@pytest.mark.parametrize("controller", ["fanuc-macro"])
@pytest.mark.parametrize("mode", ["set", "add"])
def test_every_register_component_holds_current_plus_change(controller: str, mode: str) -> None:
    rows = fixture_rows("fanuc", mode, rotation=0.0)
    program = render(controller, rows, "r.csv P1", program_number=4711)
    start = {fanuc_variable(r): START[r.id] for r in rows if r.axis != "C"}
    state = run_assignments(program, start)
    for r in rows:
        if r.axis != "C":
            assert state[fanuc_variable(r)] == pytest.approx(START[r.id] + DELTA[r.id], abs=1e-9), r.id
    assert program.startswith("%\nO4711 ") and program.endswith("M30\n%\n")
    assert PROGRAM_SUFFIX[controller] == ".nc"


@pytest.mark.parametrize("mode", ["set", "add"])
def test_haas_program_holds_current_plus_change(mode: str) -> None:
    rows = [r for r in fixture_rows("haas", mode, rotation=0.0) if r.axis != "R"]  # Haas radii are refused
    program = render("haas-macro", rows, "r.csv P1", program_number=45678)
    start = {haas_variable(r): START[r.id] for r in rows if r.axis != "C"}
    state = run_assignments(program, start)
    for r in rows:
        if r.axis != "C":
            assert state[haas_variable(r)] == pytest.approx(START[r.id] + DELTA[r.id], abs=1e-9), r.id
    assert "#7121" in program  # G154 P7 X
    assert "#2205" in program and "#2012" in program  # H5 wear, H12 geometry: the Haas map, not Fanuc's
    assert program.startswith("%\nO45678 ")


RS274_REGS = {"W1": "G54", "W2": "G55", "T5": "H5", "T12": "H12"}


def rs274_rows(mode: str) -> list[OffsetRow]:
    """The fixture rows rs274 can hold: G54/G55 X/Y/Z and the lengths H5 (wear) and H12 (geometry)."""
    out = []
    for cid, kind, axis, delta, current, offset, _ in SPEC:
        base = cid.split(".")[0]
        if base in RS274_REGS and axis in "XYZ":
            out.append(row(cid, RS274_REGS[base], kind, axis, delta, current if mode == "set" else None, offset=offset))
    return out


def test_rs274_reads_back_the_set_program_and_agrees_with_g10(tmp_path: Path) -> None:
    rows = rs274_rows("set")
    program = render("fanuc-macro", rows, "r.csv P1")
    numbers = [fanuc_variable(r) for r in rows]
    assert max(numbers) <= MAX_PARAMETER
    got = read_parameters(linuxcnc_macro(program), tmp_path, numbers, parameters={5221: 3.0, 2005: 9.0})
    for r, n in zip(rows, numbers, strict=True):
        assert got[n] == pytest.approx(START[r.id] + DELTA[r.id], abs=5e-7), r.id
    # the same rows as a G10 program: rs274 puts the work offsets in the same parameters
    g10 = render("fanuc", [r for r in rows if r.kind == "wks"], "r.csv P1")
    reads = [(p, a) for p in (1, 2) for a in "XYZ"]
    through_g10 = read_back(g10, tmp_path, reads)
    for (p, a), value in through_g10.items():
        assert value == pytest.approx(got[5221 + 20 * (p - 1) + "XYZ".index(a)], abs=5e-4)


def test_rs274_runs_the_add_program_once_and_stops_the_second_run(tmp_path: Path) -> None:
    rows = rs274_rows("add")
    program = linuxcnc_macro(render("fanuc-macro", rows, "r.csv P1"))
    numbers = [fanuc_variable(r) for r in rows]
    start = {n: START[r.id] for r, n in zip(rows, numbers, strict=True)}
    got = read_parameters(program, tmp_path, [*numbers, 549], parameters=start)
    for r, n in zip(rows, numbers, strict=True):
        assert got[n] == pytest.approx(START[r.id] + DELTA[r.id], abs=5e-7), r.id
    plan = int(re.search(r"PLAN (\d+)\)", program).group(1))  # type: ignore[union-attr]
    assert got[549] == plan
    with pytest.raises(AssertionError, match="PLAN ALREADY APPLIED"):
        read_parameters(program, tmp_path, numbers, parameters={**start, 549: float(plan)})
