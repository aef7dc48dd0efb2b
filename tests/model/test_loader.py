"""Process model loader: the spec's example loads, every listed defect is reported with file and key."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from setupfix.core.errors import ModelError
from setupfix.model import ProcessModel, load_model

SPEC_EXAMPLE = """
[process]
name = "Rear axle guide pins, 4-part fixture, B0 and B180"
axis = "Z"
unit = "mm"
resolution = 0.001
limit = 0.1

[wks.W1]
register = "G54"      # part 1 at B0
[wks.W5]
register = "G58"      # part 1 at B180

[tools.T5]
register = "H5"
[tools.T23]
register = "H23"

[features.F1]
wks = { W1 = 1 }
tools = { T5 = 1 }
[features.F3]
wks = { W5 = -1 }
tools = { T23 = -1 }
[features.F4]
wks = { W1 = 1 }
tools = { T23 = 1 }

[dimensions.D1]
name = "P1 D1"
features = { F1 = 1 }
nominal = 25.0
lower = -0.1
upper = 0.1

[dimensions.D4]
name = "P1 D4"
features = { F4 = 1, F3 = -1 }   # so D4 moves with W1 + W5 + 2*T23
nominal = 30.0
lower = -0.1
upper = 0.1
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    return path


def problems(tmp_path: Path, text: str) -> list[str]:
    with pytest.raises(ModelError) as info:
        load_model(write(tmp_path, text))
    return str(info.value).splitlines()


def test_spec_example_loads(tmp_path: Path) -> None:
    model = load_model(write(tmp_path, SPEC_EXAMPLE))
    assert model.register_ids == ["W1", "W5", "T5", "T23"]
    assert [r.register for r in model.registers] == ["G54", "G58", "H5", "H23"]
    assert model.dimensions[1].features == {"F4": 1.0, "F3": -1.0}
    assert model.unit == "mm" and model.axis == "Z" and model.resolution == 0.001
    assert all(r.limit == 0.1 and not r.fixed for r in model.registers)


def test_guide_pins_sample_loads(guide_pins_model: ProcessModel) -> None:
    assert len(guide_pins_model.wks) == 8 and len(guide_pins_model.tools) == 2
    assert len(guide_pins_model.features) == 28 and len(guide_pins_model.dimensions) == 28


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        (
            "features = { F4 = 1, F3 = -1 }",
            "features = { F4 = 1, F9 = -1 }",
            "dimensions.D4.features.F9",
            "unknown feature",
        ),
        ("wks = { W5 = -1 }", "wks = { W7 = -1 }", "features.F3.wks.W7", "unknown WKS"),
        ("tools = { T5 = 1 }", 'tools = { T5 = "one" }', "features.F1.tools.T5", "expected a number"),
        ("nominal = 30.0\nlower = -0.1\n", "nominal = 30.0\n", "dimensions.D4.lower", "missing tolerance limit"),
        (
            "lower = -0.1\nupper = 0.1\n\n[dimensions.D4]",
            "lower = 0.1\nupper = 0.1\n\n[dimensions.D4]",
            "dimensions.D1.lower",
            "must be below upper limit",
        ),
        ('unit = "mm"', 'unit = "furlong"', "process.unit", "unknown unit"),
        ('name = "P1 D4"', 'name = "p1  d1"', "dimensions.D4.name", "also used by dimension D1"),
        ('register = "H23"', 'register = "H5"', "tools.T23.register", "also used by T5"),
        ("limit = 0.1", "limit = -0.1", "process.limit", "must be > 0"),
        ("nominal = 25.0", "nominal = 25.0\nlowr = 1", "dimensions.D1.lowr", "unknown key"),
    ],
)
def test_each_defect_is_named_with_file_and_key(tmp_path: Path, old: str, new: str, key: str, words: str) -> None:
    assert old in SPEC_EXAMPLE
    lines = problems(tmp_path, SPEC_EXAMPLE.replace(old, new, 1))
    hit = [line for line in lines if f"[{key}]" in line]
    assert hit, lines
    assert "model.toml" in hit[0] and words in hit[0]


def test_all_problems_reported_together(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('unit = "mm"', 'unit = "cubit"').replace("F3 = -1 }", "F8 = -1 }")
    lines = problems(tmp_path, text)
    assert any("process.unit" in line for line in lines)
    assert any("dimensions.D4.features.F8" in line for line in lines)


def test_toml_syntax_error_names_the_line(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace("nominal = 25.0", "nominal = = 25.0")
    line_no = text.splitlines().index("nominal = = 25.0") + 1
    (line,) = problems(tmp_path, text)
    assert re.search(rf"model\.toml:{line_no}: TOML syntax", line), line


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="cannot read model"):
        load_model(tmp_path / "nope.toml")


def test_fixed_register_and_own_limit(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('register = "H23"', 'register = "H23"\nfixed = true').replace(
        'register = "G54"', 'register = "G54"\nlimit = 0.05'
    )
    model = load_model(write(tmp_path, text))
    assert model.register("H23").fixed and model.register("W1").limit == 0.05
    assert model.register("g54").id == "W1"
