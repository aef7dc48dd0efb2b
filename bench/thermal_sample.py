"""Every method on the bundled simulated sample, as ``setupfix thermal evaluate`` computes it.

    python -m bench.thermal_sample | tee bench/results/thermal_sample.txt

Train on ``sample_reports/thermal/train_variable.csv``, test on ``test_variable.csv`` and
``test_constant.csv``; target ``error_z`` (mm); default inputs (MRA/Grey: spindle_motor,
bearing, ambient; kalman: spindle_motor, bearing fused with the ambient); seed 1.
"""

from __future__ import annotations

import time
from pathlib import Path

from setupfix.usecases.thermal_fit import evaluate_files

SAMPLES = Path(__file__).resolve().parents[1] / "sample_reports" / "thermal"
RUNS = [
    ("mra", {}),
    ("grey-ls", {}),
    ("grey-cs", {}),
    ("grey-pso", {}),
    ("grey-cs", {"bound": 1.0}),
    ("grey-pso", {"bound": 1.0}),
    ("grey-cs", {"bound": 1.0, "iterations": 1000}),
    ("grey-pso", {"bound": 1.0, "iterations": 1000}),
    ("kalman", {}),
]


def main() -> None:
    print(f"{'method':<10} {'options':<28} {'test':<14} {'RMSE mm':>8} {'MR mm':>7} {'E':>7} {'fit s':>6}")
    for method, opts in RUNS:
        label = ", ".join(f"{k}={v:g}" for k, v in opts.items()) or "paper defaults"
        for test in ("test_variable.csv", "test_constant.csv"):
            t0 = time.perf_counter()
            params = {"seed": 1, **opts} if method not in ("mra", "grey-ls") else dict(opts)
            ev = evaluate_files(SAMPLES / "train_variable.csv", SAMPLES / test, method, target="error_z", params=params)
            dt = time.perf_counter() - t0
            t = ev.test
            print(
                f"{method:<10} {label:<28} {test.removesuffix('.csv'):<14} {t.rmse:>8.4f} {t.max_residual:>7.4f} "
                f"{t.efficiency:>7.3f} {dt:>6.2f}"
            )


if __name__ == "__main__":
    main()
