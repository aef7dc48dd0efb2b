"""Abdulshahed et al. (2017) Table II style comparison on the five real gooddash runs.

    python -m bench.thermal_gooddash [--seeds 5] | tee bench/results/thermal_gooddash.txt

Data: ../shared/thermal-data/gooddash (no licence: read in place, never copied).  Inputs:
the repository's six temperature-sensitive points (0-based columns 2, 6, 9, 12, 19, 20);
target E (µm).  Every run trains once and is tested on the four others (20 pairs).
Grey-CS/PSO use the paper's budget (25 agents × 100 iterations, bounds ±100, b1 > 0)
and, for reference, 10× more iterations.  Metrics on the test run without its first
sample: RMSE, maximum residual (MR), Nash–Sutcliffe E; mean over pairs (and seeds).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from setupfix.thermal.estimator import MRAModel
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.metrics import score

SHARED = Path(os.environ.get("SETUPFIX_SHARED", Path(__file__).resolve().parents[2] / "shared"))
DATA = SHARED / "thermal-data" / "gooddash"
COLS = [2, 6, 9, 12, 19, 20]


def load(i: int):
    frame = pd.read_csv(DATA / f"data_ex{i}.csv")
    return frame.iloc[:, COLS].to_numpy(), frame["E"].to_numpy()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    if not DATA.exists():
        print(f"skipped: {DATA} absent")
        return 0
    runs = {i: load(i) for i in range(1, 6)}
    methods = {
        "MRA": lambda s: MRAModel(),
        "Grey-LS (b1>0)": lambda s: GreyModel(calibration="ls"),
        "Grey-CS 25x100": lambda s: GreyModel(calibration="cs", seed=s),
        "Grey-PSO 25x100": lambda s: GreyModel(calibration="pso", seed=s),
        "Grey-CS 25x1000": lambda s: GreyModel(calibration="cs", iterations=1000, seed=s),
        "Grey-PSO 25x1000": lambda s: GreyModel(calibration="pso", iterations=1000, seed=s),
    }
    stochastic = {k for k in methods if "CS" in k or "PSO" in k}
    results: dict[str, list] = {k: [] for k in methods}
    seconds: dict[str, float] = {k: 0.0 for k in methods}
    mra_rmse: dict[tuple[int, int], float] = {}
    for name, make in methods.items():
        for tr in runs:
            for seed in range(args.seeds if name in stochastic else 1):
                t0 = time.perf_counter()
                model = make(seed).fit(*runs[tr])
                seconds[name] += time.perf_counter() - t0
                for te in runs:
                    if te == tr:
                        continue
                    X, y = runs[te]
                    s = score(y, model.predict(X, y0=y[0]))
                    results[name].append((tr, te, seed, s))
                    if name == "MRA":
                        mra_rmse[(tr, te)] = s.rmse
    print(
        f"gooddash: 5 runs (73/73/73/73/57 samples), 6 inputs, train on one, test on the 4 others; "
        f"stochastic methods over seeds 0..{args.seeds - 1}"
    )
    print(
        f"{'method':<18} {'RMSE µm':>8} {'median':>7} {'MR µm':>7} {'E':>7} {'E median':>8} "
        f"{'beats MRA':>10} {'fit s':>6}"
    )
    for name, rows in results.items():
        rmse = np.array([s.rmse for *_, s in rows])
        mr = np.array([s.max_residual for *_, s in rows])
        eff = np.array([s.efficiency for *_, s in rows])
        wins = sum(s.rmse < mra_rmse[(tr, te)] for tr, te, _, s in rows)
        fits = 5 * (args.seeds if name in stochastic else 1)
        print(
            f"{name:<18} {np.mean(rmse):>8.2f} {np.median(rmse):>7.2f} {np.mean(mr):>7.2f} {np.mean(eff):>7.2f} "
            f"{np.median(eff):>8.2f} {wins:>4}/{len(rows):<5} {seconds[name] / fits:>6.3f}"
        )
    print()
    print("per training run, mean test RMSE µm (seed-averaged):")
    print(f"{'method':<18} " + " ".join(f"{'ex' + str(i):>6}" for i in runs))
    for name, rows in results.items():
        per = [np.mean([s.rmse for tr, _, _, s in rows if tr == i]) for i in runs]
        print(f"{name:<18} " + " ".join(f"{v:>6.2f}" for v in per))
    return 0


if __name__ == "__main__":
    sys.exit(main())
