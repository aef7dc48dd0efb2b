"""Absurd models are refused with file, key and allowed range; the extension point for other sections."""

from __future__ import annotations

from pathlib import Path

import pytest
from model.test_loader import SPEC_EXAMPLE

from setupfix.core.errors import ModelError
from setupfix.model import load_model


def lines_of(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        load_model(path)
    return str(info.value).splitlines()


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        ("limit = 0.1", "limit = 1e8", "process.limit", "outside the allowed range [1e-06, 10] mm"),
        ("limit = 0.1", "limit = 1e308", "process.limit", "outside the allowed range"),
        ("resolution = 0.001", "resolution = 1e-300", "process.resolution", "allowed range [1e-06, 1] mm"),
        ("resolution = 0.001", "resolution = 1e-11", "process.resolution", "allowed range"),
        ("resolution = 0.001", "resolution = 0.5", "process.limit", "below the resolution 0.5 mm"),
        ('register = "G54"', 'register = "G54"\nlimit = 0.0005', "wks.W1.limit", "below the resolution 0.001 mm"),
        (
            "resolution = 0.001\nlimit = 0.1",
            "resolution = 0.15\nlimit = 1.0",
            "process.resolution",
            "coarser than half the narrowest tolerance band (P1 D1: 0.2 mm wide)",
        ),
        ("resolution = 0.001\nlimit = 0.1", "resolution = 0.00001\nlimit = 9.0", "process.limit", "at most 100,000"),
        ("nominal = 25.0", "nominal = 1e307", "dimensions.D1.nominal", "allowed range"),
        ("nominal = 25.0", "nominal = " + "9" * 401, "dimensions.D1.nominal", "an integer of 401 digits"),
        ("nominal = 25.0", "nominal = inf", "dimensions.D1.nominal", "not finite"),
        (
            "lower = -0.1\nupper = 0.1\n\n[dimensions.D4]",
            "lower = -1000.0\nupper = 0.1\n\n[dimensions.D4]",
            "dimensions.D1.lower",
            "allowed range [-100, 100] mm",
        ),
        ("tools = { T5 = 1 }", "tools = { T5 = 1e9 }", "features.F1.tools.T5", "[-1000, 1000]"),
        ('register = "G54"', 'register = "G54"\nlimit = nan', "wks.W1.limit", "not finite"),
    ],
)
def test_absurd_numbers_are_refused(tmp_path: Path, old: str, new: str, key: str, words: str) -> None:
    assert old in SPEC_EXAMPLE
    lines = lines_of(tmp_path, SPEC_EXAMPLE.replace(old, new, 1))
    hit = [line for line in lines if f"[{key}]" in line]
    assert hit, lines
    assert "model.toml" in hit[0] and words in hit[0], hit


def test_inch_model_ranges_are_converted(tmp_path: Path) -> None:
    text = SPEC_EXAMPLE.replace('unit = "mm"', 'unit = "inch"').replace("limit = 0.1", "limit = 0.5")
    (line,) = lines_of(tmp_path, text)
    assert "[process.limit]" in line and "0.393701] inch" in line
    ok = SPEC_EXAMPLE.replace('unit = "mm"', 'unit = "inch"').replace("resolution = 0.001", "resolution = 0.0001")
    path = tmp_path / "ok.toml"
    path.write_text(ok, encoding="utf-8")
    assert load_model(path).unit == "inch"


def test_deep_nesting_and_huge_integer_are_messages(tmp_path: Path) -> None:
    deep = SPEC_EXAMPLE + "\n[junk]\nx = " + "[" * 5000 + "]" * 5000 + "\n"
    (line,) = lines_of(tmp_path, deep)
    assert "model.toml" in line and "nested too deeply" in line
    huge = SPEC_EXAMPLE.replace("nominal = 25.0", "nominal = " + "1" * 5000)
    (line,) = lines_of(tmp_path, huge)
    assert "model.toml" in line and "out of range" in line


def test_safety_and_register_settings_are_typed_fields_with_key_paths(tmp_path: Path) -> None:
    """[safety] and a register's cost load into typed fields (no registry); problems name file and key."""
    text = SPEC_EXAMPLE.replace('register = "H5"', 'register = "H5"\ncost = 2.5') + "\n[safety]\ngain = 0.5\n"
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    model = load_model(path)
    assert model.safety.gain == 0.5 and model.register("T5").policy.cost == 2.5 and model.register("T5").cost == 2.5
    assert model.register("T23").cost == 1.0 and not model.effects
    (line,) = lines_of(tmp_path, text.replace("cost = 2.5", "cost = -1"))
    assert "[tools.T5.cost]" in line and "expected a number in (0, ∞)" in line
    (line,) = lines_of(tmp_path, text.replace("gain = 0.5", "gain = -1"))  # sections: once the rest is valid
    assert "[safety.gain]" in line and "expected a number in (0, 1]" in line
    (line,) = lines_of(tmp_path, text.replace("gain = 0.5", "band = 1"))
    assert "[safety.band]" in line and "unknown key" in line


def test_unknown_section_still_refused(tmp_path: Path) -> None:
    # ([safety] itself is registered by setupfix.model.safety)
    (line,) = lines_of(tmp_path, SPEC_EXAMPLE + "\n[safetee]\nband = 1\n")
    assert "[safetee]" in line and "unknown table" in line
