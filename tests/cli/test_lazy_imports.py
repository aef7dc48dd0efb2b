"""The CLI starts light: building the parser loads no numpy, pandas or scipy."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_import_and_parser_load_no_numeric_stack() -> None:
    code = (
        "import sys, setupfix.cli as c; c.build_parser(); "
        "print(','.join(m for m in ('numpy', 'pandas', 'scipy', 'highspy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_help_and_version_exit_zero_without_the_numeric_stack() -> None:
    code = (
        "import sys, setupfix.cli as c; s = c.main(['--version']); assert s == 0, s; assert 'numpy' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True)


def test_parser_choices_match_the_registries() -> None:
    from setupfix.cli import choices as _choices
    from setupfix.optimize import OPTIMIZERS
    from setupfix.outputs.controllers import CONTROLLERS
    from setupfix.thermal.registry import methods
    from setupfix.usecases.history import EXPORTS
    from setupfix.usecases.simulate import START

    assert set(_choices.OPTIMIZERS) == set(OPTIMIZERS)
    assert set(_choices.CONTROLLERS) == set(CONTROLLERS)
    assert _choices.HISTORY_EXPORTS == EXPORTS
    assert methods() == _choices.THERMAL_METHODS
    assert _choices.SIMULATE_START == START
