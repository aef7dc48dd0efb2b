"""Regenerate the simulated temperature logs of this folder.

    python sample_reports/thermal/generate.py

Three runs of the default simulated machine (:class:`setupfix.thermal.simulator.MachineConfig`),
10 s sampling, 4 h each (1440 samples): ``train_variable.csv`` and ``test_variable.csv``
under random speed steps 0–3000 rpm (different seeds), ``test_constant.csv`` at a constant
1300 rpm.  Columns: timestamp, spindle_motor, bearing, ambient (°C), spindle_speed (rpm),
error_z (mm).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from setupfix.core.atomic import atomic_write
from setupfix.thermal.simulator import simulate, speed_profile

HERE = Path(__file__).resolve().parent
N = 1440

RUNS = {
    "train_variable.csv": ("variable", 1),
    "test_variable.csv": ("variable", 7),
    "test_constant.csv": ("constant", 11),
}


def main() -> None:
    for name, (kind, seed) in RUNS.items():
        speed = speed_profile(kind, N, rng=np.random.default_rng(seed))
        run = simulate(speed, seed=seed)
        with atomic_write(HERE / name) as stream:
            run.frame.to_csv(stream, index=False, lineterminator="\n")
        print(f"wrote {name}: {len(run.frame)} samples, max error {run.frame['error_z'].abs().max():.4f} mm")


if __name__ == "__main__":
    main()
