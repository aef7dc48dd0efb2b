"""Fixtures of the thermal tests: small simulated logs and ../shared access."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    from setupfix.thermal.simulator import SimulatedRun

SHARED = Path(os.environ.get("SETUPFIX_SHARED", Path(__file__).resolve().parents[3] / "shared"))
SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "thermal"


def shared_path(*parts: str) -> Path:
    """Path below ../shared, skipping the test with a reason when it is absent."""
    path = SHARED.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): shared thermal data not available")
    return path


@pytest.fixture(scope="session")
def sim_runs() -> tuple[SimulatedRun, SimulatedRun]:
    """Two simulated runs (4 h at 10 s): variable-speed training and test.

    Shorter training logs leave the noise ratio N/R of the fusion model unconstrained
    (any ratio fits clean data), which is why the robustness tests use 4 h.
    """
    from setupfix.thermal.simulator import simulate, speed_profile

    n = 1440
    train = simulate(speed_profile("variable", n, rng=np.random.default_rng(1)), seed=1)
    test = simulate(speed_profile("variable", n, rng=np.random.default_rng(7)), seed=7)
    return train, test
