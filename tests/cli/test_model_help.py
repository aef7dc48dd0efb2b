"""Wording: the terms in --help, every option of the model commands with a help text, 100 columns."""

from __future__ import annotations

import argparse

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import build_parser, main


def test_terms_are_explained_in_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for term in ("error budget", "bonus", "margin", "predicted", "binding"):
        assert f"\n  {term} " in out


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def test_every_option_of_the_model_commands_has_help() -> None:
    model = _subparsers(build_parser())["model"]
    commands = _subparsers(model)
    assert set(commands) >= {"show", "check", "init"}
    for name, parser in commands.items():
        for action in parser._actions:
            assert action.help, (name, action.dest)
    correct = _subparsers(build_parser())["correct"]
    for dest in ("parts_per_cycle", "strict", "stations"):
        (action,) = [a for a in correct._actions if a.dest == dest]
        assert action.help


def test_model_show_fits_100_columns(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["model", "show", str(GUIDE_PINS / "model.toml")]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert "R_WF (columns 1–19 of 28)" in out and "R_WF (columns 20–28 of 28)" in out
    assert "null space (1 direction(s))" in out
