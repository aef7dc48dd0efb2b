"""Issue 12: every thermal method on a real log split in time (fit on the first 40 %, predict the rest).

    OPENBLAS_NUM_THREADS=1 python -m bench.thermal_split | tee bench/results/thermal_split.txt

Data: ../shared/thermal-data/gooddash (no licence: read in place; SETUPFIX_SHARED names the
folder when the checkout is elsewhere).  Each of the five runs is one spindle log: 22
temperature rises from the first sample (K) and the thermal error E (µm), no timestamp
(read with time counted in samples).  The first 40 % of the samples train, the rest is
predicted as a log of its own — it starts warm, which is what the stored reference
state is for.  Yardstick: a plain least-squares regression with intercept on the
temperatures.  "old mra" is the behaviour before the reference state (rises from the
test log's own first sample).  Every method through the registry and the pipeline
(`pipeline.thermal_fit.fit_log` / `pipeline.thermal.predict_log`), kalman through its documented fallback
(no spindle speed, no ambient column).  Grey methods with both response forms (eq. 2
trapezoid and Tien's).  RMSE on the test part without its first sample, µm.
"Diverges" = a prediction beyond 10× the largest measured |E|.  BLAS threads limited to 1
(threadpoolctl); fit times as a ratio to the mra fit in the same run.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from parsers.temperature import read_temperature_log
from setupfix.thermal.metrics import score
from setupfix.thermal.prediction import predict_log
from setupfix.thermal.registry import methods
from setupfix.usecases.thermal_fit import fit_log

DATA = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent / "shared")) / "thermal-data" / "gooddash"
SPLIT = 0.4


def variants():
    for name in methods():
        if name.startswith("grey-"):
            for form in ("trapezoid", "tien"):
                yield f"{name}/{form}", name, {"form": form}
        else:
            yield name, name, {}


def main() -> int:
    if not DATA.exists():
        print(f"skipped: {DATA} absent")
        return 0
    rows: dict[str, list[float]] = {}
    times: dict[str, list[float]] = {}
    diverged: dict[str, int] = {}
    runs = []
    static: dict[str, list[str]] = {}
    for i in range(1, 6):
        log = read_temperature_log(DATA / f"data_ex{i}.csv", require_time=False)
        n = log.n
        k = int(SPLIT * n)
        train, test = log.head(k), log.slice(k, n)
        runs.append(f"ex{i} ({k}/{n - k})")
        inputs = [c for c in log.columns if c != "E"]
        T = np.column_stack([log.columns[c] for c in inputs])
        E = log.columns["E"]
        A = np.column_stack([T, np.ones(n)])
        beta, *_ = np.linalg.lstsq(A[:k], E[:k], rcond=None)
        rows.setdefault("regression (yardstick)", []).append(score(E[k:], A[k:] @ beta).rmse)
        dT = T - T[0]
        b_old, *_ = np.linalg.lstsq(dT[:k], E[:k], rcond=None)
        rows.setdefault("old mra (rises from the log's start)", []).append(score(E[k:], (T[k:] - T[k]) @ b_old).rmse)
        for label, name, params in variants():
            t0 = time.perf_counter()
            saved = fit_log(train, name, target="E", params=params, unit="um").saved
            times.setdefault(label, []).append(time.perf_counter() - t0)
            pred = predict_log(saved, test)[0]
            rows.setdefault(label, []).append(score(E[k:], pred).rmse)
            diverged[label] = diverged.get(label, 0) + int(np.max(np.abs(pred)) > 10 * np.max(np.abs(E)))
            if name.startswith("grey-"):
                # Static limit of eq. (2): ½ Σ_j b_j x_j^(0)(k) (rises from the reference), from sample 3 on.
                theta = saved.model.theta_
                half = 0.5 * (T[k:] - saved.model.T_ref_) @ theta[1:-1]
                gap = np.max(np.abs((pred - saved.model.y_ref_ - half)[3:]))
                static.setdefault(label, []).append(f"b1 {theta[0]:7.3g} gap {gap:8.2g}")
    print(
        f"gooddash runs, 22 temperatures, E in µm; fit on the first {SPLIT:.0%}, predict the rest; "
        "test RMSE µm (first test sample excluded)"
    )
    print(
        f"{'method':38s}" + "".join(f"{r:>15s}" for r in runs) + f"{'mean':>8s}{'vs regr.':>10s}"
        f"{'diverges':>10s}{'fit time':>10s}"
    )
    ref = np.mean(rows["regression (yardstick)"])
    t_ref = np.mean(times["mra"])
    for label, vals in rows.items():
        extra = f"{diverged[label]:>7d}/5{np.mean(times[label]) / t_ref:>9.0f}x" if label in diverged else ""
        print(
            f"{label:38s}" + "".join(f"{v:15.2f}" for v in vals) + f"{np.mean(vals):8.2f}"
            f"{np.mean(vals) / ref - 1:+10.1%}" + extra
        )
    print("fit time: mean over the runs as a multiple of the mra fit (same run, 1 BLAS thread)")
    print()
    print(
        "static limit of eq. (2): fitted b1 (per sample) and max |prediction - 1/2 sum_j b_j dT_j| "
        "from the 4th test sample on, µm"
    )
    for label, vals in static.items():
        print(f"{label:20s}" + "  ".join(vals))
    return 0


if __name__ == "__main__":
    with threadpool_limits(1):
        raise SystemExit(main())
