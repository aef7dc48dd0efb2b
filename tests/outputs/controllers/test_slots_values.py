"""Programs that cannot hurt the machine (issue 37, item 16 b–e): the offset a register's letter names, slots
each control has, values no control holds, and the unit of a rotation in the offsets CSV.

Each case is a variant of the issue's: ``D7`` (not ``D5``) for a length, an edge 0 given by the name as well as
by ``edge``, values at the 100 m bound in mm, in inch and in degrees.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math

import pytest
from multi_axis_rows import fixture_rows, row

from parsers.current import MAX_OFFSET_MM
from setupfix.core.errors import ExportError
from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.controllers import CONTROLLERS, render
from setupfix.outputs.writers import ROTATION_UNIT, offsets_csv_text


@pytest.mark.parametrize("name", ["fanuc", "haas"])
@pytest.mark.parametrize("register", ["D7", "d 07"])
@pytest.mark.parametrize("current", [None, 0.25])
def test_a_length_in_a_d_register_is_refused_not_written_to_the_diameter(
    name: str, register: str, current: float | None
) -> None:
    length = row("T7", register, "tool", "Z", -0.011, current, offset="wear")
    with pytest.raises(ExportError) as info:
        render(name, [length])
    message = str(info.value)
    assert repr(register) in message and "T7" in message and "H7" in message
    # the same change in the H register is a length-wear block, and a radius in the D register a diameter block
    assert "G10 L11 P7 R" in render(name, [row("T7", "H7", "tool", "Z", -0.011, current, offset="wear")])
    assert "G10 L13 P7 R" in render(name, [row("T7.R", register, "tool", "R", -0.011, current, offset="wear")])


@pytest.mark.parametrize(
    ("controller", "tool", "why"),
    [
        ("siemens", row("T3", "T3 D0", "tool", "Z", 0.01, offset="wear"), "cutting edge D 0"),
        ("siemens", row("T3", "Probe", "tool", "Z", 0.01, offset="wear", number=3, edge=0), "cutting edge D 0"),
        ("siemens", row("T0", "T0 D2", "tool", "Z", 0.01, offset="wear"), "tool number T 0"),
        ("siemens", row("T0", "Probe", "tool", "Z", 0.01, offset="wear", number=0, edge=1), "tool number T 0"),
        ("siemens", row("T9", "T9 D32001", "tool", "Z", 0.01, offset="wear"), "cutting edge D 32001"),
        ("heidenhain", row("T0", "T0", "tool", "Z", 0.01, 0.1, offset="wear"), "tool number 0"),
        ("heidenhain", row("W1", "G54", "wks", "Z", 0.01, -400.0, number=0), "preset row 0"),
        ("heidenhain", row("W1", "PRESET 0", "wks", "Z", 0.01, -400.0), "preset row 0"),
        ("fanuc", row("T0", "H0", "tool", "Z", 0.01, offset="wear"), "offset number 0"),
        ("haas", row("T201", "H201", "tool", "Z", 0.01, offset="wear"), "offset number 201"),
    ],
)
def test_a_slot_the_control_does_not_have_is_refused(controller: str, tool: OffsetRow, why: str) -> None:
    with pytest.raises(ExportError) as info:
        render(controller, [tool])
    assert why in str(info.value) and "does not exist" in str(info.value)


def test_the_lowest_real_slots_are_written() -> None:
    text = render("siemens", [row("T1", "T1 D1", "tool", "Z", 0.01, offset="wear")])
    assert "$TC_DP12[1,1]=$TC_DP12[1,1]+0.010" in text
    assert "\n1  +0.110\n" in render("heidenhain", [row("T1", "T1", "tool", "Z", 0.01, 0.1, offset="wear")])


BOUND_INCH = MAX_OFFSET_MM / 25.4


@pytest.mark.parametrize("name", list(CONTROLLERS))
@pytest.mark.parametrize(
    ("current", "unit", "axis"),
    [
        (MAX_OFFSET_MM, "mm", "Z"),  # the bound itself: |value| < bound, as the current-offsets reader
        (-2.5 * MAX_OFFSET_MM, "mm", "X"),
        (BOUND_INCH + 1.0, "inch", "Z"),  # 100 m in inch
        (math.nan, "mm", "Z"),
    ],
)
def test_a_value_no_control_holds_is_never_written(name: str, current: float, unit: str, axis: str) -> None:
    huge = row("W1", "G54", "wks", axis, 0.002, current, unit=unit, number=1)
    with pytest.raises(ExportError) as info:
        render(name, [huge])
    assert "beyond any control's offset range" in str(info.value) and "'G54'" in str(info.value)
    # just inside the bound: written (in mm; the inch row just inside its own bound)
    inside = BOUND_INCH - 1.0 if unit == "inch" else MAX_OFFSET_MM - 1.0
    assert render(name, [row("W1", "G54", "wks", axis, 0.002, inside, unit=unit, number=1)])


def test_a_rotation_is_bounded_in_degrees_not_in_the_length_unit() -> None:
    spin = row("W1.C", "G54", "wks", "C", 0.01, MAX_OFFSET_MM * 1.5, number=1)
    with pytest.raises(ExportError, match="degrees"):
        render("siemens", [spin])
    # an inch model: 5,000 degrees is far below the bound in degrees, though 3,937 inch is 100 m
    assert render("siemens", [row("W1.C", "G54", "wks", "C", 0.01, 5000.0, unit="inch", number=1)])


@pytest.mark.parametrize("mode", ["add", "set"])
@pytest.mark.parametrize("unit", ["mm", "inch"])
def test_the_offsets_csv_labels_a_rotation_in_degrees(mode: str, unit: str) -> None:
    rows = [dataclasses.replace(r, unit=unit) for r in fixture_rows("siemens", mode, rotation=0.02)]
    table = list(csv.DictReader(io.StringIO(offsets_csv_text(rows))))
    units = {r["id"]: r["unit"] for r in table}
    assert units["W1.C"] == ROTATION_UNIT == "deg"
    assert {u for i, u in units.items() if not i.endswith(".C")} == {unit}  # lengths keep the model unit
    assert render("csv", rows) == offsets_csv_text(rows)
