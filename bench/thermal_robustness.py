"""Wang et al. (2017) §4 on the simulator: fused model vs MRA under sensor errors and failure.

    python -m bench.thermal_robustness [--seeds 5] | tee bench/results/thermal_robustness.txt

Training: 4 h variable-speed run (seed 1).  Test Case 1: 4 h at 1300 rpm; Case 2: 4 h of
other random speed steps.  Sensor errors on the spindle-motor sensor: eq. (18)
2 sin(t/350) °C, eq. (19) −2 °C from the start, and −2 °C appearing after 80 min (a step);
"sensors failed" predicts with gain 0 throughout (lumped-mass model alone).  RMSV
(eq. 13) and MR (eq. 17) in mm, mean over GA seeds (MRA has no randomness).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from setupfix.thermal.estimator import MRAModel
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.kalman_model import KalmanFusionModel
from setupfix.thermal.metrics import score
from setupfix.thermal.simulator import (
    add_sensor_error,
    constant_error,
    simulate,
    sinusoidal_error,
    speed_profile,
)

SENSORS = ["spindle_motor", "bearing"]
N = 1440


def arrays(frame):
    return (
        frame[SENSORS].to_numpy(),
        frame["error_z"].to_numpy(),
        frame["ambient"].to_numpy(),
        frame["spindle_speed"].to_numpy(),
    )


def step_error(t):
    return np.where(np.asarray(t) >= 4800.0, -2.0, 0.0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    train = simulate(speed_profile("variable", N, rng=np.random.default_rng(1)), seed=1)
    cases = {
        "Case 1 (1300 rpm)": simulate(speed_profile("constant", N, level=1300.0), seed=11),
        "Case 2 (variable)": simulate(speed_profile("variable", N, rng=np.random.default_rng(7)), seed=7),
    }
    conditions = {
        "no sensor error": lambda f: f,
        "sinusoidal eq.18": lambda f: add_sensor_error(f, "spindle_motor", sinusoidal_error),
        "constant eq.19": lambda f: add_sensor_error(f, "spindle_motor", constant_error),
        "constant, step at 80 min": lambda f: add_sensor_error(f, "spindle_motor", step_error),
        "sensors failed (K=0)": None,
    }
    T, y, te, sp = arrays(train.frame)
    mra = MRAModel().fit(T, y)
    gls = GreyModel(calibration="ls").fit(T, y)
    t0 = time.perf_counter()
    fused = [KalmanFusionModel(seed=s).fit(T, y, ambient=te, speed=sp) for s in range(args.seeds)]
    fit_s = (time.perf_counter() - t0) / args.seeds
    print(f"training: {N} samples at 10 s; kalman fit {fit_s:.2f} s per seed; seeds 0..{args.seeds - 1}")
    print("fitted N/R per sensor (seed 0):", np.array2string(fused[0].q_, precision=3))
    kalman_rmsv = np.mean([score(y, m.predict(T, ambient=te, speed=sp)).rmsv for m in fused])
    mra_rmsv, grey_rmsv = score(y, mra.predict(T)).rmsv, score(y, gls.predict(T, y0=y[0])).rmsv
    print(f"fit RMSV mm: kalman {kalman_rmsv:.4f}  mra {mra_rmsv:.4f}  grey-ls {grey_rmsv:.4f}")
    print()
    print(
        f"{'case':<19} {'condition':<26} {'RMSV fused':>10} {'RMSV MRA':>9} {'RMSV GMC-LS':>11} "
        f"{'MR fused':>9} {'MR MRA':>8}"
    )
    for cname, run in cases.items():
        for kname, corrupt in conditions.items():
            frame = run.frame if corrupt is None else corrupt(run.frame)
            T2, y2, te2, sp2 = arrays(frame)
            failed = corrupt is None
            kf = [score(y2, m.predict(T2, ambient=te2, speed=sp2, sensors_failed=failed)) for m in fused]
            if failed:
                mra_s = gls_s = None
            else:
                mra_s = score(y2, mra.predict(T2))
                gls_s = score(y2, gls.predict(T2, y0=y2[0]))
            print(
                f"{cname:<19} {kname:<26} {np.mean([s.rmsv for s in kf]):>10.4f} {fmt(mra_s, 'rmsv'):>9} "
                f"{fmt(gls_s, 'rmsv'):>11} {np.mean([s.max_residual for s in kf]):>9.4f} "
                f"{fmt(mra_s, 'max_residual'):>8}"
            )


def fmt(scores: object | None, metric: str) -> str:
    """One metric of a score, or n/a when the method was not run."""
    return "n/a" if scores is None else f"{getattr(scores, metric):.4f}"


if __name__ == "__main__":
    main()
