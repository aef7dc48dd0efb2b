"""Multi-axis models (spec *Multi-axis models*): registers per component, new keys, one-line refusals."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from setupfix.core.errors import ModelError
from setupfix.model import ProcessModel, load_model

BASE = """
[process]
name = "two axes"
axes = ["X", "Y", "Z"]
rotation = true
rotation_limit = 0.02
rotation_resolution = 0.0002

[wks.W1]
register = "G54"
[wks.W2]
register = "G55"
axes = ["Z", "X"]
rotation = false

[tools.T1]
register = "H1"
radius = "D1"
radius_limit = 0.03
[tools.T2]
register = "H2"

[features.F1]
wks = { W1 = 1 }
position = [10.0, 20.0, 0.0]
tools = { T1 = 1 }
radius = { T1 = -1 }
[features.F2]
wks = { W1 = { x = -1, y = 1, z = -1, c = 0 }, W2 = 1 }

[dimensions.D1]
name = "Height"
axis = "Z"
features = { F1 = 1 }
nominal = 5.0
lower = -0.05
upper = 0.05

[dimensions.D2]
name = "Normal"
direction = [0.6, 0.0, 0.8]
features = { F2 = 1 }
nominal = 0.0
lower = -0.05
upper = 0.05

[dimensions.D3]
name = "Bore"
kind = "size"
features = { F1 = 2 }
nominal = 10.0
lower = -0.02
upper = 0.02

[dimensions.D4]
name = "Hole"
kind = "position"
components = ["Hole X", "Hole Y"]
axes = ["X", "Y"]
diameter = 0.1
features = { F1 = 1 }
"""


def load(tmp_path: Path, text: str) -> ProcessModel:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    return load_model(path)


def refused(tmp_path: Path, text: str) -> list[str]:
    with pytest.raises(ModelError) as info:
        load(tmp_path, text)
    lines = str(info.value).splitlines()
    assert all("model.toml" in line for line in lines), lines
    return lines


def test_components_are_registers_in_file_order(tmp_path: Path) -> None:
    m = load(tmp_path, BASE)
    assert m.multi_axis and m.axes == ("X", "Y", "Z") and m.spindle == "Z"
    assert m.register_ids == ["W1.X", "W1.Y", "W1.Z", "W1.C", "W2.X", "W2.Z", "T1", "T1.R", "T2"]
    regs = {r.id: r for r in m.registers}
    assert regs["W1.C"].component == "C" and regs["W1.C"].limit == 0.02 and regs["W1.C"].register == "G54"
    assert regs["T1"].component == "Z" and regs["T1"].register == "H1"
    assert regs["T1.R"].register == "D1" and regs["T1.R"].limit == 0.03 and regs["T1.R"].component == "R"
    assert {r.base for r in m.wks} == {"W1", "W2"}
    assert m.resolution_of(regs["W1.C"]) == 0.0002 and m.resolution_of(regs["W1.X"]) == 0.001
    f2 = m.features[1]
    assert f2.components == {"W1": {"x": -1.0, "y": 1.0, "z": -1.0}, "W2": dict.fromkeys("xyzc", 1.0)}
    dims = {d.id: d for d in m.dimensions}
    assert dims["D2"].direction == pytest.approx((0.6, 0.0, 0.8))
    assert dims["D1"].direction == (0.0, 0.0, 1.0)
    assert dims["D3"].kind == "size"
    zone = dims["D4"]
    assert zone.zone and zone.lower == 0.0 and zone.upper == 0.05 and zone.plane == ("X", "Y")
    assert zone.keys == () and zone.component_keys == ("hole x", "hole y")


def test_one_axis_file_unchanged(tmp_path: Path) -> None:
    text = "\n".join(
        line
        for line in BASE.splitlines()
        if not line.startswith(("axes", "rotation", "radius", "direction", "kind", "components", "diameter", "axis"))
    )
    text = text.replace("{ W1 = { x = -1, y = 1, z = -1, c = 0 }, W2 = 1 }", "{ W1 = -1, W2 = 1 }")
    text = text.replace(
        '[dimensions.D4]\nname = "Hole"\n', '[dimensions.D4]\nname = "Hole"\nnominal = 0\nlower = -0.05\nupper = 0.05\n'
    )
    m = load(tmp_path, text)
    assert not m.multi_axis and m.register_ids == ["W1", "W2", "T1", "T2"]
    assert all(r.component is None and r.owner is None for r in m.registers)
    assert m.features[1].wks == {"W1": -1.0, "W2": 1.0} and m.features[1].components == {}


@pytest.mark.parametrize(
    ("edit", "key", "words"),
    [
        (('axes = ["X", "Y", "Z"]', 'axes = ["X", "X"]'), "process.axes", "distinct"),
        (('axes = ["X", "Y", "Z"]', 'axes = ["X", "Y", "Z"]\nspindle = "B"'), "process.spindle", '"X", "Y" or "Z"'),
        (("rotation_limit = 0.02", "rotation_limit = -1"), "process.rotation_limit", "> 0"),
        (("rotation_resolution = 0.0002", "rotation_resolution = 0.5"), "process.rotation_resolution", "above"),
        (('axes = ["Z", "X"]', 'axes = ["Z", "B"]'), "wks.W2.axes", "axes"),
        (("rotation = false", "rotation = 1"), "wks.W2.rotation", "true or false"),
        (('radius = "D1"', "radius = 5"), "tools.T1.radius", "register name"),
        (("radius_limit = 0.03", "radius_limit = 0"), "tools.T1.radius_limit", "> 0"),
        (("radius = { T1 = -1 }", "radius = { T2 = -1 }"), "features.F1.radius.T2", "no radius register"),
        (("c = 0 }", "q = 0 }"), "features.F2.wks.W1.q", "unknown component"),
        (("direction = [0.6, 0.0, 0.8]", "direction = [1.0, 1.0, 0.0]"), "dimensions.D2.direction", "unit vector"),
        (("direction = [0.6, 0.0, 0.8]", 'direction = "up"'), "dimensions.D2.direction", "[nx, ny, nz]"),
        (('axis = "Z"', 'axis = "W"'), "dimensions.D1.axis", '"X", "Y" or "Z"'),
        (('kind = "size"', 'kind = "volume"'), "dimensions.D3.kind", '"size" or "position"'),
        (("diameter = 0.1\n", ""), "dimensions.D4.diameter", "needs its diameter"),
        (("diameter = 0.1", "diameter = -0.1"), "dimensions.D4.diameter", "> 0"),
        (('components = ["Hole X", "Hole Y"]', 'components = ["Hole X"]'), "dimensions.D4.components", "two"),
        (('axes = ["X", "Y"]\n', ""), "dimensions.D4.axes", "plane"),
        (("diameter = 0.1", "diameter = 0.1\nlower = -0.1"), "dimensions.D4.lower", "diameter"),
        (
            ("nominal = 10.0\nlower = -0.02", "nominal = 10.0\ndiameter = 1\nlower = -0.02"),
            "dimensions.D3.diameter",
            "only a position zone",
        ),
        (("position = [10.0, 20.0, 0.0]\n", ""), "features.F1.position", "rotation of W1"),
    ],
)
def test_each_new_key_refused_on_one_line(tmp_path: Path, edit: tuple[str, str], key: str, words: str) -> None:
    old, new = edit
    assert old in BASE
    lines = refused(tmp_path, BASE.replace(old, new, 1))
    hit = [line for line in lines if key in line]
    assert hit, lines
    assert words in hit[0], hit


def test_multi_axis_keys_refused_in_a_one_axis_model(tmp_path: Path) -> None:
    text = BASE.replace('axes = ["X", "Y", "Z"]\n', "", 1)
    lines = refused(tmp_path, text)
    assert any("process.rotation" in line and "multi-axis key" in line for line in lines)
    assert any("tools.T1.radius" in line and "multi-axis key" in line for line in lines)
    assert any("dimensions.D4.kind" in line for line in lines)


def test_zone_component_names_must_not_collide(tmp_path: Path) -> None:
    """Two zones may not share a component; a dimension may also be a zone's component (issue 37)."""
    other = '\n[dimensions.D5]\nname = "Hole 2"\nkind = "position"\ncomponents = ["Hole X", "Hole 2 Y"]\n'
    lines = refused(tmp_path, BASE + other + 'axes = ["X", "Y"]\ndiameter = 0.1\nfeatures = { F1 = 1 }\n')
    assert any("dimensions.D5" in line and "also a component of position zone D4" in line for line in lines)
    m = load(tmp_path, BASE.replace('name = "Height"', 'name = "Hole X"'))
    assert [d.id for d in m.dimensions if "hole x" in (*d.keys, *d.component_keys)] == ["D1", "D4"]


def test_direction_is_normalised_within_tolerance(tmp_path: Path) -> None:
    m = load(tmp_path, BASE.replace("direction = [0.6, 0.0, 0.8]", "direction = [0.6004, 0.0, 0.8]"))
    n = next(d for d in m.dimensions if d.id == "D2").direction
    assert n is not None and math.isclose(math.hypot(*n), 1.0)


def test_machine_points_refused_in_multi_axis(tmp_path: Path) -> None:
    lines = refused(tmp_path, BASE + "\n[machine.M1]\nwks = { W1 = 1 }\n")
    assert any("machine" in line and "multi-axis" in line for line in lines)


def test_zone_components_match_and_are_suggested(tmp_path: Path) -> None:
    import numpy as np
    import pandas as pd

    from setupfix.model import match_parts, suggest_names

    m = load(tmp_path, BASE)
    table = pd.DataFrame(
        {
            "characteristic": ["hole  x", "HOLE Y", "Height", "Hole1 X"],
            "deviation": [0.03, -0.04, 0.01, 0.0],
            "unit": "mm",
        }
    )
    (part,) = match_parts(m, table)
    q = [d.id for d in m.dimensions].index("D4")
    assert part.zone is not None and part.zone[q].tolist() == [0.03, -0.04]
    assert part.deviation[q] == pytest.approx(0.05)
    assert np.isnan(part.zone[0]).all()
    assert part.unmatched == ("Hole1 X",) and suggest_names(m, "Hole1 X")[0] == "Hole X"
    assert part.names[q] == "hole  x + HOLE Y"
