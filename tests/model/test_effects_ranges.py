"""[effects] values are checked when the model loads (issue 21, item 11): one line per problem, file and key."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from model.test_loader import SPEC_EXAMPLE

from setupfix.core.errors import ModelError
from setupfix.model import load_model
from setupfix.model.effects_toml import effects_toml
from setupfix.model.process import ProcessModel

DRIFT = '[effects.E1]\nkind = "drift"\nestimate = 0.002\nunit = "mm/h"\n'


def load(tmp_path: Path, extra: str, base: str = SPEC_EXAMPLE) -> ProcessModel:
    path = tmp_path / "model.toml"
    path.write_text(base + "\n" + extra, encoding="utf-8")
    return load_model(path)


def refusal(tmp_path: Path, extra: str, base: str = SPEC_EXAMPLE) -> str:
    with pytest.raises(ModelError) as info:
        load(tmp_path, extra, base)
    (line,) = str(info.value).splitlines()
    assert re.match(re.escape(str(tmp_path / "model.toml")) + r":\d+: \[effects", line), line
    return line


@pytest.mark.parametrize(
    ("extra", "key", "words"),
    [
        ('[effects]\norigin = "yesterday"\n' + DRIFT, "effects.origin", "ISO 8601"),
        ("[effects]\norigin = 1e308\n" + DRIFT, "effects.origin", "ISO 8601"),
        ("[effects]\norigin = 08:00:00\n" + DRIFT, "effects.origin", "ISO 8601"),
        ('[effects]\norigin = "0001-01-01T00:00:00"\n' + DRIFT, "effects.origin", "year 1 is outside 1970…2200"),
        ("[effects]\ncycle_hours = 1e308\n" + DRIFT, "effects.cycle_hours", "[0, 8784]"),
        ("[effects]\ncycle_hours = -1.0\n" + DRIFT, "effects.cycle_hours", "[0, 8784]"),
        ("[effects]\nlast_hours = inf\n" + DRIFT, "effects.last_hours", "found inf"),
        ('[effects]\nlast_hours = "13"\n' + DRIFT, "effects.last_hours", "found '13'"),
        (DRIFT.replace("0.002", "1e6"), "effects.E1.estimate", "plausible ±1 mm/h of a drift effect"),
        (DRIFT.replace("0.002", "1e308"), "effects.E1.estimate", "plausible ±1 mm/h"),
        (DRIFT.replace("0.002", "nan"), "effects.E1.estimate", "expected a finite number, found nan"),
        (DRIFT.replace("0.002", "9" * 400), "effects.E1.estimate", "beyond the float range"),
        (DRIFT.replace("0.002", '"fast"'), "effects.E1.estimate", "found 'fast'"),
        (DRIFT + "stderr = -0.1\n", "effects.E1.stderr", "expected a number in [0, 1000]"),
        (DRIFT.replace('"drift"', '"drift"\nshape = "saturating"\ntau = 0.0'), "effects.E1.tau", "(0, 100000]"),
        (DRIFT.replace('"drift"', '"drift"\nshape = "saturating"\ntau = 1e9'), "effects.E1.tau", "(0, 100000]"),
        (
            DRIFT.replace('"drift"', '"drift"\nshape = "saturating"\ntau = 2.0').replace("0.002", "50.0"),
            "effects.E1.estimate",
            "±10 mm of a saturating drift effect",
        ),
        (
            '[effects.E2]\nkind = "thermal"\nchannel = "spindle"\nreference = 1e5\nestimate = 0.001\n',
            "effects.E2.reference",
            "°C in [-50, 200]",
        ),
        ('[effects.E2]\nkind = "thermal"\nchannel = "spindle"\nestimate = 5.0\n', "effects.E2.estimate", "±1 mm/°C"),
        ('[effects.E3]\nkind = "wear"\nregister = "T5"\nestimate = -3.0\n', "effects.E3.estimate", "±1 mm/cycle"),
        ('[effects.E4]\nkind = "scale"\nestimate = 0.5\n', "effects.E4.estimate", "±0.01 (a ratio)"),
        ('[effects.E5]\nkind = "position"\naxis = "x"\nestimate = -0.2\n', "effects.E5.estimate", "±0.01"),
        (
            '[effects.E6]\nkind = "relation"\nregister = "T5"\ndimension = "D1"\nestimate = 1e4\n',
            "effects.E6.estimate",
            "±1000 (a weight)",
        ),
        (DRIFT + "unit = 3\n", "effects.E1", ""),  # TOML: a key twice is a syntax error (checked below)
    ][:-1],
)
def test_each_effects_value_is_checked_at_load(tmp_path: Path, extra: str, key: str, words: str) -> None:
    line = refusal(tmp_path, extra)
    assert f"[{key}]" in line and words in line, line


def test_wrong_types_of_text_keys_are_named(tmp_path: Path) -> None:
    line = refusal(tmp_path, DRIFT.replace('unit = "mm/h"', "unit = 3"))
    assert "[effects.E1.unit]" in line and "expected a string, found 3" in line


def test_bounds_follow_the_model_unit(tmp_path: Path) -> None:
    inch = SPEC_EXAMPLE.replace('unit = "mm"', 'unit = "inch"').replace("resolution = 0.001", "resolution = 0.0001")
    line = refusal(tmp_path, DRIFT.replace("0.002", "0.05"), inch)
    assert "plausible ±0.0393701 inch/h" in line
    assert load(tmp_path, DRIFT.replace("0.002", "0.03"), inch).effects.effects[0].estimate == 0.03


def test_plausible_section_loads_and_round_trips(tmp_path: Path) -> None:
    text = (
        "[effects]\norigin = 2026-11-02T08:00:00\ncycle_hours = 0.333\nlast_hours = 13.0\n"
        + DRIFT
        + 'stderr = 0.0001\n[effects.E2]\nkind = "thermal"\nchannel = "spindle"\nreference = 20.0\n'
        'estimate = -0.0011\n[effects.E3]\nkind = "wear"\nregister = "T5"\nestimate = 0.0004\n'
    )
    model = load(tmp_path, text)
    section = model.effects
    assert [e.kind for e in section.effects] == ["drift", "thermal", "wear"]
    assert section.origin == "2026-11-02 08:00:00" and section.cycle_hours == 0.333
    again = load(tmp_path, effects_toml(section))
    assert again.effects == section
