"""The one reader of the controller's current offsets (``--current FILE``): bad rows refused with file:line."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from parsers.current import read_current
from setupfix.cli import main
from setupfix.core.errors import ParseError
from setupfix.model import load_model, model_from_dict

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_reports" / "controllers"
MODEL = load_model(SAMPLE / "model.toml")
GOOD = "register,value\nG54,-412.53\nG55,-412.487\nH5,-0.012\nH12,0.0035\n"


def test_the_sample_is_read_by_register_id() -> None:
    assert read_current(SAMPLE / "current.csv", MODEL) == {"W1": -412.53, "W2": -412.487, "T5": -0.012, "T12": 0.0035}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("reg,val\nG54,1\n", "c.csv:1: expected the header 'register,value'"),
        ("register,value\nG99,1\n", "c.csv:2: register 'G99' is not in the model"),
        ("register,value\nG54,1_0\n", "c.csv:2: expected a decimal number, found '1_0'"),
        ("register,value\nG54,1\nG55,1\nH5,0\n", "no current value for H12"),
        ("register,value\nG54,1\nW1,2\n", "c.csv:3: register 'W1' given twice"),
        # a decimal comma: read as -412 before, 0.53 mm wrong
        (GOOD.replace("G54,-412.53", "G54,-412,5300"), "c.csv:2: 3 cells but 2 columns in the header"),
        (GOOD.replace("H5,-0.012", "H5,nan"), "c.csv:4: expected a decimal number, found 'nan'"),
        (GOOD.replace("H5,-0.012", "H5,-inf"), "c.csv:4: expected a decimal number, found '-inf'"),
        (GOOD.replace("H5,-0.012", "H5,1e400"), "c.csv:4: expected a decimal number, found '1e400'"),
        (GOOD.replace("G55,-412.487", "G55,-100000"), "c.csv:3: value -100000 of G55 is beyond any control's offset"),
        (GOOD.replace("G55,-412.487", "G55,4.2e7"), "c.csv:3: value 4.2e7 of G55 is beyond any control's offset"),
    ],
)
def test_bad_current_file(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "c.csv").write_text(text)
    with pytest.raises(ParseError, match=re.escape(message)):
        read_current(tmp_path / "c.csv", MODEL)


def test_a_comment_column_is_refused_and_the_limit_follows_the_model_unit(tmp_path: Path) -> None:
    (tmp_path / "c.csv").write_text(
        GOOD.replace("register,value", "register,value,comment").replace("G54,-412.53", "G54,-412.53,checked")
    )
    with pytest.raises(ParseError, match=re.escape("c.csv:1: expected the header 'register,value', found")):
        read_current(tmp_path / "c.csv", MODEL)
    inch = model_from_dict(
        {
            "process": {"name": "t", "unit": "inch"},
            "wks": {"W1": {"register": "G54"}},
            "features": {"F": {"wks": {"W1": 1}}},
            "dimensions": {"D": {"features": {"F": 1}, "nominal": 1, "lower": -0.01, "upper": 0.01}},
        }
    )
    (tmp_path / "i.csv").write_text("register,value\nG54,3937.1\n")  # 100,002 mm
    with pytest.raises(ParseError, match=re.escape("i.csv:2: value 3937.1 of G54 is beyond")):
        read_current(tmp_path / "i.csv", inch)
    (tmp_path / "i.csv").write_text("register,value\nG54,3937.0\n")
    assert read_current(tmp_path / "i.csv", inch) == {"W1": 3937.0}


def test_correct_refuses_a_decimal_comma_in_current_with_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "c.csv"
    bad.write_text(GOOD.replace("G54,-412.53", "G54,-412,5300"))
    out = tmp_path / "o.csv"
    code = main(
        [
            "correct",
            "--model",
            str(SAMPLE / "model.toml"),
            "--current",
            str(bad),
            "--offsets",
            str(out),
            str(SAMPLE / "report.csv"),
        ]
    )
    err = capsys.readouterr().err
    assert code != 0 and err.startswith(f"error: {bad}:2: 3 cells but 2 columns") and err.count("\n") == 1
    assert not out.exists()


ONE = model_from_dict(
    {
        "process": {"name": "one register"},
        "wks": {"W1": {"register": "G54"}},
        "features": {"F": {"wks": {"W1": 1}}},
        "dimensions": {"D": {"features": {"F": 1}, "nominal": 1, "lower": -0.01, "upper": 0.01}},
    }
)


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("G54,-412,5300", "c.csv:2: 3 cells but 2 columns in the header"),
        ("G54,-412,53", "c.csv:2: 3 cells but 2 columns in the header"),
        ("G54,1e6", "c.csv:2: value 1e6 of G54 is beyond any control's offset"),
        ("G54,1e300", "c.csv:2: value 1e300 of G54 is beyond any control's offset"),
        ("G54,-1e300", "c.csv:2: value -1e300 of G54 is beyond any control's offset"),
        ("G54,inf", "c.csv:2: expected a decimal number, found 'inf'"),
    ],
)
@pytest.mark.parametrize("end", ["\n", "", "\r\n"])
def test_one_row_files_are_refused_like_longer_ones(tmp_path: Path, rows: str, message: str, end: str) -> None:
    """A file of one register row (no second row to compare with) and its last row without a line end."""
    (tmp_path / "c.csv").write_text(f"register,value{end or chr(10)}{rows}{end}", newline="")
    with pytest.raises(ParseError, match=re.escape(message)):
        read_current(tmp_path / "c.csv", ONE)


@pytest.mark.parametrize("row", ["H12,0,0035", "H12,1e6", "H12,1e300"])
def test_the_last_row_of_a_longer_file_is_checked(tmp_path: Path, row: str) -> None:
    (tmp_path / "c.csv").write_text(GOOD.replace("H12,0.0035\n", row))  # no line end after it
    with pytest.raises(ParseError, match=r"c\.csv:5: "):
        read_current(tmp_path / "c.csv", MODEL)
