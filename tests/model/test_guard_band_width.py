"""A guard band that leaves no conformance zone is refused with its key (issue 37 item 16): 2·g·U at or
beyond a tolerance's width (g·U at or beyond a zone's radius) proves nothing in tolerance, so no correction
is solved on a collapsed zone and shown as APPLY."""

from __future__ import annotations

from pathlib import Path

import pytest

from setupfix.cli import main
from setupfix.core.errors import ModelError
from setupfix.model import load_model

ONE_AXIS = """\
[process]
name = "guard"
resolution = 0.001
limit = 0.1

[wks.W1]
register = "G54"

[features.F1]
wks = { W1 = 1 }

[dimensions.A]
name = "Depth A"
features = { F1 = 1 }
nominal = 10
lower = -0.05
upper = 0.05

[dimensions.B]
name = "Depth B"
features = { F1 = 1 }
nominal = 20
lower = -0.2
upper = 0.2

[dimensions.C]
name = "Step C"
features = { F1 = 1 }
nominal = 5
lower = -0.02
upper = 0.08
"""

ZONE = """\
[process]
name = "zone guard"
axes = ["X", "Y"]
resolution = 0.001
limit = 0.1

[wks.W1]
register = "G54"

[features.H]
wks = { W1 = 1 }
position = [10.0, 10.0, 0.0]

[dimensions.Z]
name = "Hole"
features = { H = 1 }
kind = "position"
components = ["Hole X", "Hole Y"]
axes = ["X", "Y"]
diameter = 0.1
"""


def load(tmp_path: Path, text: str) -> str:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    return str(info.value)


@pytest.mark.parametrize(
    ("safety", "key", "named"),
    [
        ("uncertainty = 0.06", "[safety.uncertainty]", "A (Depth A)"),  # the issue's ±0.05 case
        ("uncertainty = 0.05", "[safety.uncertainty]", "A (Depth A)"),  # exactly the width: one point
        ("uncertainty = 0.1\nguard_band = 0.5", "[safety.uncertainty]", "C (Step C)"),  # 0.5 × 0.1 × 2
        ("uncertainty = 0.01\n[safety.dimensions.B]\nuncertainty = 0.25", "[safety.dimensions.B.uncertainty]", "B"),
    ],
)
def test_a_guard_band_wider_than_a_tolerance_is_refused(tmp_path: Path, safety: str, key: str, named: str) -> None:
    message = load(tmp_path, ONE_AXIS + "\n[safety]\n" + safety + "\n")
    assert "model.toml:" in message and key in message and named in message
    assert "no conformance zone is left" in message


def test_a_guard_band_as_wide_as_a_zones_radius_is_refused(tmp_path: Path) -> None:
    message = load(tmp_path, ZONE + "\n[safety]\nuncertainty = 0.05\n")
    assert "[safety.uncertainty]" in message and "Z (Hole)" in message and "radius 0.05" in message


@pytest.mark.parametrize(
    ("text", "safety"),
    [
        (ONE_AXIS, "uncertainty = 0.019"),  # 0.038 < 0.1 on the narrowest one
        (ONE_AXIS, "uncertainty = 0.06\nguard_band = 0.4"),  # 0.048 < 0.1
        (ONE_AXIS, "uncertainty = 0.01\n[safety.dimensions.B]\nuncertainty = 0.19"),  # 0.38 < 0.4
        (ZONE, "uncertainty = 0.049"),
    ],
    ids=["narrow", "guard-fraction", "own-U", "zone"],
)
def test_a_guard_band_that_leaves_a_zone_is_accepted(tmp_path: Path, text: str, safety: str) -> None:
    path = tmp_path / "model.toml"
    path.write_text(text + "\n[safety]\n" + safety + "\n", encoding="utf-8")
    assert load_model(path).safety.uncertainty > 0


def test_correct_refuses_it_with_one_line_and_nothing_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model, report, offsets = tmp_path / "model.toml", tmp_path / "r.csv", tmp_path / "o.csv"
    model.write_text(ONE_AXIS + "\n[safety]\nuncertainty = 0.06\n", encoding="utf-8")
    report.write_text("characteristic,nominal,actual\nDepth A,10,10.01\nDepth B,20,20.02\nStep C,5,5.03\n")
    code = main(["correct", "--model", str(model), "--offsets", str(offsets), str(report)])
    out, err = capsys.readouterr()
    assert code == 1 and out == "" and not offsets.exists()
    assert "[safety.uncertainty]" in err and "Traceback" not in err and "APPLY" not in err
