"""``--current`` in a multi-axis model: ``register,axis,value``, one row per register component, by component ID."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from multi_axis_rows import multi_axis_model

from parsers.current import read_current
from setupfix.core.errors import ParseError

MODEL = multi_axis_model()
GOOD = (
    "register,axis,value\nG54,X,-250.123\nG54,Y,120.5\nG54,Z,-412.53\nG54,C,0.25\n"
    "G55,X,50\nG55,Y,-0.5\nG55,Z,-412.487\nH5,,-0.012\nD5,,0.002\n"
)
WANT = {
    "W1.X": -250.123,
    "W1.Y": 120.5,
    "W1.Z": -412.53,
    "W1.C": 0.25,
    "W2.X": 50.0,
    "W2.Y": -0.5,
    "W2.Z": -412.487,
    "T5": -0.012,
    "T5.R": 0.002,
}


def test_every_component_by_its_id(tmp_path: Path) -> None:
    (tmp_path / "c.csv").write_text(GOOD)
    assert read_current(tmp_path / "c.csv", MODEL) == WANT


def test_model_ids_lower_case_axes_and_a_fixed_register(tmp_path: Path) -> None:
    text = (
        GOOD.replace("G54,X,", "W1,x,")
        .replace("H5,,", "T5,,")
        .replace("D5,,", "T5.R,,")
        .replace("register,axis,value", " Register , Axis,VALUE")
        + "H7,,1.5\n"
    )
    (tmp_path / "c.csv").write_text(text)
    assert read_current(tmp_path / "c.csv", MODEL) == {**WANT, "T7": 1.5}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("register,value\nG54,1\n", "c.csv:1: expected the header 'register,axis,value' (a multi-axis model"),
        (GOOD + "G99,X,1\n", "c.csv:11: register 'G99' is not in the model"),
        (GOOD.replace("G54,Y,", "G54,,"), "c.csv:3: register 'G54' is a work offset: give its axis (X, Y, Z or C)"),
        (GOOD.replace("G55,Z,", "G55,C,"), "c.csv:8: register 'G55' has no axis 'C' in the model (its axes: X, Y, Z)"),
        (GOOD.replace("H5,,", "H5,Z,"), "c.csv:9: register 'H5' is a tool register: leave its axis empty"),
        (GOOD + "G54,Z,1\n", "c.csv:11: register 'G54 Z' given twice"),
        (GOOD + "T5.R,,0\n", "c.csv:11: register 'T5.R' given twice"),
        (GOOD.replace("G55,Z,-412.487\n", "").replace("D5,,0.002\n", ""), "c.csv: no current value for G55 Z, D5"),
        (GOOD.replace("G54,Z,-412.53", "G54,Z,-412,53"), "c.csv:4: 4 cells but 3 columns in the header"),
        (GOOD.replace("G54,C,0.25", "G54,C,nan"), "c.csv:5: expected a decimal number, found 'nan'"),
        (GOOD.replace("G55,X,50", "G55,X,-100000"), "c.csv:6: value -100000 of G55 X is beyond any control's offset"),
        (
            GOOD.replace("G54,C,0.25", "G54,C,1e5"),
            "c.csv:5: value 1e5 of G54 C is beyond any control's offset range (|value| < 100000 degrees)",
        ),
        (GOOD.replace("D5,,0.002", "D5,"), "c.csv:10: expected register,axis,value"),
    ],
)
def test_refused_naming_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "c.csv").write_text(text)
    with pytest.raises(ParseError, match=re.escape(message)):
        read_current(tmp_path / "c.csv", MODEL)


def test_the_limit_follows_the_model_unit_but_not_for_a_rotation(tmp_path: Path) -> None:
    inch = multi_axis_model("inch")
    (tmp_path / "c.csv").write_text(GOOD.replace("G55,X,50", "G55,X,3937.1"))
    with pytest.raises(ParseError, match=re.escape("c.csv:6: value 3937.1 of G55 X is beyond")):
        read_current(tmp_path / "c.csv", inch)
    (tmp_path / "c.csv").write_text(GOOD.replace("G54,C,0.25", "G54,C,3937.1"))
    assert read_current(tmp_path / "c.csv", inch)["W1.C"] == 3937.1
