"""An incremental program loaded twice never doubles the correction (issue 37, item 8).

An *add* program checks its plan number at the top and records it at the end (Fanuc/Haas: the common variable
``#549`` and a ``#3000`` alarm; Siemens: ``R99`` and a jump past every change), so a second run stops before any
change.  Variants of the issue's case: the sample's one-axis plan and a multi-axis plan with tool radii, run by
the project's G10 interpreter (:mod:`g10`), by a Siemens interpreter below, and by LinuxCNC's ``rs274`` (the Fanuc
``IF … THEN`` line, which it does not know, mapped to its ``o-if``); a second plan after the first still runs.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest
from g10 import Alarm, run_g10
from multi_axis_rows import fixture_rows
from rs274 import run_rs274

from setupfix.correction.offsets import OffsetRow, offset_rows
from setupfix.model import load_model
from setupfix.outputs.controllers import render
from setupfix.outputs.controllers.common import GUARD_R, GUARD_VARIABLE, PLANS

ROOT = Path(__file__).resolve().parents[3]
SAMPLE = ROOT / "sample_reports" / "controllers"
MODEL = load_model(SAMPLE / "model.toml")
GUARD = re.compile(r"^IF \[#(\d+) EQ (\d+)\] THEN #3000=\d+ \((.*)\)$", re.M)


def one_axis(delta: float = -0.008) -> list[OffsetRow]:
    changes = {"W1": 0.011, "W2": -0.004, "T5": delta, "T12": 0.003}
    return offset_rows(MODEL, changes, report="r7.csv", part="cycle 9", verdict="apply")


PLANS_UNDER_TEST = {
    "one-axis": lambda name: one_axis(),
    "multi-axis": lambda name: fixture_rows(name, "add", rotation=0.0),
}


def plan_of(program: str) -> int:
    found = re.findall(r"PLAN (\d+)", program, re.I)
    assert found and len(set(found)) == 1
    return int(found[0])


@pytest.mark.parametrize("name", ["fanuc", "haas"])
@pytest.mark.parametrize("which", list(PLANS_UNDER_TEST))
def test_a_second_run_of_a_g10_program_stops_before_any_change(name: str, which: str) -> None:
    program = render(name, PLANS_UNDER_TEST[which](name), "r7.csv cycle 9")
    lines = program.splitlines()
    blocks = [i for i, line in enumerate(lines) if " G10 " in line]
    guard = next(i for i, line in enumerate(lines) if GUARD.match(line))
    record = lines.index(f"#{GUARD_VARIABLE}={plan_of(program)}")
    assert guard < blocks[0] and record > blocks[-1] and lines[record + 1] == "M30"
    start = {(2, 1, "Z"): -412.5, (11, 5, "R"): 0.01}
    once = run_g10(program, start)
    assert once[(0, GUARD_VARIABLE, "#")] == plan_of(program)
    with pytest.raises(Alarm, match="PLAN ALREADY APPLIED"):
        run_g10(program, once)
    # another plan (another change) after the first runs, and guards itself in turn
    if which == "one-axis":
        other = render(name, one_axis(-0.002), "r8.csv cycle 10")
        assert plan_of(other) != plan_of(program)
        twice = run_g10(other, once)
        assert twice[(11, 5, "R")] == pytest.approx(0.01 - 0.008 - 0.002)
        with pytest.raises(Alarm):
            run_g10(other, twice)


def test_the_plan_number_names_the_plan_not_the_program() -> None:
    rows = one_axis()
    a = render("fanuc", rows, "r7.csv cycle 9", program_number=1234)
    assert plan_of(a) == plan_of(render("fanuc", rows, "r7.csv cycle 9", program_number=5678))  # renumbered
    assert plan_of(a) != plan_of(render("fanuc", one_axis(-0.009), "r7.csv cycle 9", program_number=1234))
    assert plan_of(a) != plan_of(render("fanuc", rows, "r8.csv cycle 9", program_number=1234))
    assert all(PLANS[0] <= plan_of(render("haas", one_axis(d / 1000), "t")) <= PLANS[1] for d in range(-20, 20))


@pytest.mark.parametrize("name", ["fanuc", "haas", "siemens"])
def test_an_absolute_program_needs_no_guard(name: str) -> None:
    current = {r.id: 1.0 for r in one_axis()}
    rows = [dataclasses.replace(r, mode="set", current=current[r.id], value=1.0 + r.delta) for r in one_axis()]
    program = render(name, rows, "r7.csv cycle 9")
    assert "PLAN" not in program.upper() and f"#{GUARD_VARIABLE}" not in program and GUARD_R not in program


def run_siemens(program: str, state: dict[str, float]) -> dict[str, float]:
    """The part program's assignments on ``state``, with ``IF Rn==v GOTOF L`` jumps, labels, ``M0``/``M30``
    (``MSG`` is recorded under ``"MSG"``)."""
    out = dict(state)
    lines = program.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].split(";")[0].strip()
        i += 1
        if not line or line.startswith("%") or line.endswith(":"):
            continue
        if line in ("M30", "M0"):
            if line == "M30":
                return out
            continue
        jump = re.fullmatch(r"IF (R\d+)==(\d+) GOTOF (\w+)", line)
        if jump:
            if out.get(jump.group(1)) == float(jump.group(2)):
                i = lines.index(f"{jump.group(3)}:") + 1
            continue
        message = re.fullmatch(r'MSG\("(.*)"\)', line)
        if message:
            out["MSG"] = 1.0
            continue
        assign = re.fullmatch(r"(\$[^=]+|R\d+)=(?:\1)?([-+]?[\d.]+)", line)
        assert assign, f"not a line this reader knows: {line!r}"
        incremental = line.count(assign.group(1)) == 2
        out[assign.group(1)] = (out.get(assign.group(1), 0.0) if incremental else 0.0) + float(assign.group(2))
    raise AssertionError("no M30")


@pytest.mark.parametrize("which", list(PLANS_UNDER_TEST))
def test_a_second_run_of_a_siemens_program_jumps_past_every_change(which: str) -> None:
    program = render("siemens", PLANS_UNDER_TEST[which]("siemens"), "r7.csv cycle 9", program_number=77)
    start = {"$TC_DP12[5,1]": 0.01}
    once = run_siemens(program, start)
    assert once[GUARD_R] == plan_of(program) and "MSG" not in once
    again = run_siemens(program, once)
    assert again == {**once, "MSG": 1.0}  # nothing changed, the message shown


#: Blocks rs274 reads otherwise than Fanuc (its tool table, L20 from the position): left out, as test_rs274 does.
NOT_FOR_RS274 = re.compile(r"^G9[01] G10 L(?:1[0-3]|20) .*\n", re.M)


def linuxcnc(program: str) -> str:
    """The Fanuc guard line in LinuxCNC's syntax (``o-if`` and ``abort``), a read of the guard variable before
    ``M30``; the G10 L2 blocks, comments and the record line as written."""
    m = GUARD.search(program)
    assert m
    mapped = f"o100 if [#{m.group(1)} EQ {m.group(2)}]\n(abort, {m.group(3)})\no100 endif"
    text = NOT_FOR_RS274.sub("", program.replace(m.group(0), mapped))
    assert re.search(r"^G91 G10 L2 ", text, re.M)
    return text.replace("\nM30\n", f"\n(debug, #{GUARD_VARIABLE})\nM30\n")


@pytest.mark.parametrize("which", list(PLANS_UNDER_TEST))
def test_rs274_reads_the_guarded_program_and_stops_a_second_run(tmp_path: Path, which: str) -> None:
    program = render("fanuc", PLANS_UNDER_TEST[which]("fanuc"), "r7.csv cycle 9", program_number=4711)
    text = linuxcnc(program)
    (recorded,) = run_rs274(text, tmp_path)
    assert float(recorded) == plan_of(program)
    with pytest.raises(AssertionError, match="PLAN ALREADY APPLIED"):
        run_rs274(text, tmp_path, {GUARD_VARIABLE: float(plan_of(program))})
    (other,) = run_rs274(text, tmp_path, {GUARD_VARIABLE: float(plan_of(program) - 1)})  # another plan ran last
    assert float(other) == plan_of(program)
