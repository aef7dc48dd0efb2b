"""The generated reference pages hold every command, option and model key, and are up to date."""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _generator() -> ModuleType:
    spec = importlib.util.spec_from_file_location("setupfix_reference", ROOT / "docs/_ext/setupfix_reference.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("setupfix_reference", module)
    spec.loader.exec_module(module)
    return module


gen = _generator()


def _section(text: str, path: tuple[str, ...]) -> str:
    """The part of the CLI page under the heading of one command, up to the next command's heading."""
    title = "`setupfix" + "".join(f" {p}" for p in path) + "`"
    m = re.search(rf"^#+ {re.escape(title)}$", text, re.M)
    assert m, f"no heading for {title}"
    nxt = re.search(r"^#+ `setupfix", text[m.end() :], re.M)
    return text[m.end() : m.end() + nxt.start() if nxt else len(text)]


@pytest.mark.slow
def test_committed_pages_are_the_generated_ones() -> None:
    """docs/reference/cli.md and model-keys.md are what the generator writes now (the build rewrites them)."""
    hint = "run python docs/_ext/setupfix_reference.py"
    assert gen.CLI_PAGE.read_text(encoding="utf-8") == gen.cli_markdown(), hint
    assert gen.KEYS_PAGE.read_text(encoding="utf-8") == gen.keys_markdown(), hint


def test_every_command_and_option_is_in_the_reference() -> None:
    from setupfix.cli import build_parser

    text = gen.CLI_PAGE.read_text(encoding="utf-8")
    seen = 0
    for path, parser in gen.commands(build_parser()):
        section = _section(text, path)
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name in action.choices:
                    assert f"| `{name}` |" in section, f"setupfix {' '.join(path)}: command {name} missing"
                continue
            names = action.option_strings or [str(action.metavar or action.dest)]
            for name in names:
                assert re.search(rf"`{re.escape(name)}[ `]", section), f"setupfix {' '.join(path)}: {name} missing"
                seen += 1
    assert seen > 200  # every command's options, not an empty walk


def test_a_missing_option_is_caught() -> None:
    """The check above fails for an option the page lacks (a test that cannot fail is a defect)."""
    text = gen.CLI_PAGE.read_text(encoding="utf-8")
    broken = text.replace("`--program-number N`", "`--program N`")
    with pytest.raises(AssertionError):
        assert re.search(r"`--program-number[ `]", _section(broken, ("correct",)))


def test_every_model_key_is_in_the_reference() -> None:
    from setupfix.model import axes, effects, loader, safety, stations, tables

    text = gen.KEYS_PAGE.read_text(encoding="utf-8")
    keys = set().union(
        *tables.TABLE_KEYS.values(),
        *axes.MULTI_KEYS.values(),
        safety.SAFETY_KEYS,
        safety.REGISTER_KEYS,
        safety.DIMENSION_KEYS,
        effects.EFFECT_KEYS,
        stations.STATION_KEYS,
        stations.TEMPLATE_KEYS,
    )
    for key in sorted(keys):
        assert f"`{key}`" in text, f"model key {key} missing from docs/reference/model-keys.md"
    for section in (*tables.TABLE_KEYS, *loader.SECTIONS, *loader.EXPANDED_SECTIONS):
        assert f"`[{section}" in text, f"model table [{section}] missing"


def test_every_effect_kind_is_in_the_reference() -> None:
    from setupfix.model.effects import EFFECT_KINDS

    text = gen.KEYS_PAGE.read_text(encoding="utf-8")
    for kind in EFFECT_KINDS:
        assert f"`{kind}`" in text


def test_the_effects_head_keys_are_the_loaders() -> None:
    """The [effects] head keys the generator lists load, and a key beside them is refused."""
    import tomllib

    from setupfix.core.errors import ModelError
    from setupfix.model.loader import model_from_dict

    base = tomllib.loads((ROOT / "sample_reports/guide_pins/model.toml").read_text(encoding="utf-8"))
    head = {"origin": "2026-11-02T06:00:00", "cycle_hours": 0.5, "last_hours": 2.0}
    assert set(head) == gen.EFFECTS_HEAD
    model_from_dict({**base, "effects": head})
    with pytest.raises(ModelError):
        model_from_dict({**base, "effects": {**head, "origin_time": 1.0}})
