"""Shared fixtures: paths to the bundled samples and to ../shared."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from setupfix.model import ProcessModel

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "sample_reports"
#: ../shared beside the project; SETUPFIX_SHARED names it elsewhere (a worktree outside the checkout).
SHARED = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent / "shared"))
GUIDE_PINS = SAMPLES / "guide_pins"


@pytest.fixture
def guide_pins_model() -> ProcessModel:
    from setupfix.model import load_model

    return load_model(GUIDE_PINS / "model.toml")


def shared_path(*parts: str) -> Path:
    """Path below ../shared, skipping the test with a reason when it is absent."""
    path = SHARED.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): shared sample not available")
    return path
