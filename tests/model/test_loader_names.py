"""Control characters in a model's IDs and names (issue 21, item 12).

IDs (table keys) and register names are refused at load; names (process, dimension
name, aliases, group) are free text: they load as written and the tables escape them.
"""

from __future__ import annotations

import io
from contextlib import redirect_stdout
from pathlib import Path

import pytest
from model.test_loader import SPEC_EXAMPLE

from setupfix.cli import main
from setupfix.core.errors import ModelError
from setupfix.model import load_model


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("old", "new", "key", "char"),
    [
        ('register = "H5"', 'register = "H5\\n"', "tools.T5.register", "U+000A"),
        ("[dimensions.D1]", '[dimensions."D1\\n"]', "dimensions.D1?", "U+000A"),
        ("[wks.W1]", '[wks."W\\u00071"]', "wks.W?1", "U+0007"),
    ],
)
def test_control_characters_in_ids_and_names_are_refused(
    tmp_path: Path, old: str, new: str, key: str, char: str
) -> None:
    assert old in SPEC_EXAMPLE
    text = SPEC_EXAMPLE.replace(old, new, 1)
    if old == "[wks.W1]":
        text = text.replace("W1 = 1", '"W\\u00071" = 1')
    with pytest.raises(ModelError) as info:
        load_model(write(tmp_path, text))
    lines = str(info.value).splitlines()
    hit = [line for line in lines if f"[{key}]" in line and char in line]
    assert hit, lines
    assert "model.toml" in hit[0] and "one line of printable text" in hit[0]


FREE_TEXT = 'name = "P1\\nD1"\ngroup = "A\\u001b[2JB"\naliases = ["x\\u2028y"]'


def test_names_are_free_text_and_escaped_in_the_correct_table(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('name = "P1 D1"', FREE_TEXT, 1)
    path = write(tmp_path, text)
    model = load_model(path)
    assert model.dimensions[0].name == "P1\nD1" and model.dimensions[0].group == "A\x1b[2JB"
    report = tmp_path / "r.csv"
    report.write_text(
        "characteristic,nominal,actual,lower,upper\nP1 D1,25.0,25.05,-0.1,0.1\nP1 D4,30.0,30.0,-0.1,0.1\n",
        encoding="utf-8",
    )
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["correct", "--model", str(path), str(report)]) == 0
    text = out.getvalue()
    assert "\x1b" not in text and "\r" not in text
    row = next(line for line in text.splitlines() if line.startswith("A?[2JB"))  # the station column
    assert "P1?D1" in row and "+0.05" in row


def test_ordinary_names_still_load(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('name = "P1 D1"', 'name = "P1 Ø\u00a0D1 – 表"')
    assert load_model(write(tmp_path, text)).dimensions[0].name == "P1 Ø\u00a0D1 – 表"


def test_process_name_with_a_newline_is_escaped_in_model_show(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('name = "Rear axle', 'name = "Rear\\naxle\\u001b[2J', 1)
    path = write(tmp_path, text)
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["model", "show", str(path)]) == 0
    first = out.getvalue().splitlines()[0]
    assert first.startswith("Rear?axle?[2J guide pins") and "(axis Z" in first
    assert "\x1b" not in out.getvalue()
