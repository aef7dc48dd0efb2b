"""A register's letter names the offset a program writes (issue 37, item 16 b): a tool length in a ``D`` register
(written ``G10 L12``/``L13``, the diameter) or a radius in an ``H`` register refuses the model, naming file,
line and key.  Variants of the issue's ``register = "D5"``: another number, a spelling with a blank and leading
zero, a slot given by ``number``, and a multi-axis tool's radius in an H register.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from model.test_loader import SPEC_EXAMPLE

from setupfix.core.errors import ModelError
from setupfix.model import load_model

ROOT = Path(__file__).resolve().parents[2]
XYZ = ROOT / "sample_reports" / "two_station_xyz" / "model.toml"


@pytest.mark.parametrize("spelling", ['register = "D23"', 'register = "d 023"', 'register = "D23"\nnumber = 23'])
def test_a_tool_length_in_a_d_register_refuses_the_model(tmp_path: Path, spelling: str) -> None:
    text = SPEC_EXAMPLE.replace('register = "H23"', spelling)
    assert text != SPEC_EXAMPLE
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    (line,) = str(info.value).splitlines()
    at = text.splitlines().index("[tools.T23]") + 2  # the register's own line
    assert line.startswith(f"{path}:{at}: [tools.T23.register]: ")
    assert "D (radius/diameter)" in line and "H23" in line


def test_a_radius_in_an_h_register_refuses_the_multi_axis_model(tmp_path: Path) -> None:
    text = XYZ.read_text(encoding="utf-8").replace('radius = "D1"', 'radius = "H7"')
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    (line,) = str(info.value).splitlines()
    assert "[tools.T1.radius]" in line and "'H7'" in line and "D7" in line


def test_the_right_letters_load() -> None:
    model = load_model(XYZ)
    assert {r.register for r in model.tools} >= {"H1", "D1", "H2"}
