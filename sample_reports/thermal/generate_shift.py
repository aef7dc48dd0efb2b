"""Regenerate ``shift_2026-11-02.csv``: a temperature log of the day the guide-pins cycles were cut.

    python sample_reports/thermal/generate_shift.py

The run of ``test_variable.csv`` (the default simulated machine, random speed steps 0–3000 rpm, seed 7,
10 s sampling, 4 h) started at 2026-11-02T06:00:00 instead of 2026-01-05T06:00:00, so that it covers
``sample_reports/guide_pins/cycle_01.csv`` (measured 2026-11-02T08:00:00) and ``correct --thermal``
can join the parts' time to it (docs/howto/thermal.md). Simulated, not measured.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from setupfix.core.atomic import atomic_write
from setupfix.thermal.simulator import MachineConfig, simulate, speed_profile

HERE = Path(__file__).resolve().parent
N = 1440
SEED = 7
START = "2026-11-02T06:00:00"


def main() -> None:
    speed = speed_profile("variable", N, rng=np.random.default_rng(SEED))
    run = simulate(speed, replace(MachineConfig(), start=START), seed=SEED)
    with atomic_write(HERE / "shift_2026-11-02.csv") as stream:
        run.frame.to_csv(stream, index=False, lineterminator="\n")
    print(f"wrote shift_2026-11-02.csv: {len(run.frame)} samples from {START}")


if __name__ == "__main__":
    main()
