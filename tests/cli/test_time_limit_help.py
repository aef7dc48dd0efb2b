"""``--time-limit`` says what it is (issue 37 item 4): the hang guard, with the solver's real default."""

from __future__ import annotations

import argparse

import pytest

from setupfix.cli import build_parser
from setupfix.optimize.exact.solve import DEFAULT_TIME_LIMIT


@pytest.mark.parametrize("command", ["correct", "batch", "compare"])
def test_the_time_limit_help_gives_the_guards_default(command: str) -> None:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    (option,) = [a for a in sub.choices[command]._actions if "--time-limit" in a.option_strings]
    assert option.help is not None and f"(default {DEFAULT_TIME_LIMIT:g})" in option.help
    assert "guard" in option.help and "work limits" in option.help
