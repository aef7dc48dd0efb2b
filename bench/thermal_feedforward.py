"""Issue 12: thermal drift fed forward into the corrections, on the real gooddash runs.

    OPENBLAS_NUM_THREADS=1 python -m bench.thermal_feedforward | tee bench/results/thermal_feedforward.txt

Data: ../shared/thermal-data/gooddash (no licence: read in place; SETUPFIX_SHARED names the
folder elsewhere); 22 temperature rises, error E in µm, one sample = one part cycle.

Protocol (one correction every N samples, N = 6, 12, 24): at sample c = N, 2N, … the
report of the parts cut at c − N arrives and the setup correction cancels their error
E(c − N); the parts cut at samples c … c + N − 1 then keep the error

    r(k) = E(k) − E(c − N) − F(c)

with F(c) the thermal feed-forward added to that correction:

* no model: F = 0;
* change since measured (what ``setupfix correct --thermal`` adds):
  F = Ê(c) − Ê(c − N), :func:`setupfix.thermal.feedforward.drift_change`;
* absolute drift (``predict_drift(...).latest``, to show why not): F = Ê(c).

Models are fitted on one run (through the registry and the pipeline, default seeds)
and applied to the four others (20 pairs); kalman through its documented fallback (no
speed, no ambient).  RMS of r over all parts cut after the first correction, µm,
averaged over the pairs; no dead band (every change is fed forward).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from parsers.temperature import read_temperature_log
from setupfix.thermal.feedforward import drift_change
from setupfix.thermal.prediction import predict_log
from setupfix.thermal.registry import methods
from setupfix.usecases.thermal_fit import fit_log

DATA = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent / "shared")) / "thermal-data" / "gooddash"
INTERVALS = (6, 12, 24)
VARIANTS = (
    [("mra", "mra", {})]
    + [(f"{m}/tien", m, {"form": "tien"}) for m in methods() if m.startswith("grey-")]
    + [(m, m, {}) for m in methods() if m.startswith("grey-")]
    + [("kalman", "kalman", {})]
)


def residual(E: np.ndarray, drift: np.ndarray | None, N: int, mode: str) -> float:
    n = E.size
    times = np.arange(n, dtype=float)
    res = []
    for c in range(N, n, N):
        if drift is None:
            F = 0.0
        elif mode == "change":
            F = float(drift_change(drift, times, c - N, at=c))
        else:
            F = float(drift[c])
        k = np.arange(c, min(c + N, n))
        res.append(E[k] - E[c - N] - F)
    r = np.concatenate(res)
    return float(np.sqrt(np.mean(r * r)))


def main() -> int:
    if not DATA.exists():
        print(f"skipped: {DATA} absent")
        return 0
    logs = {i: read_temperature_log(DATA / f"data_ex{i}.csv", require_time=False) for i in range(1, 6)}
    table: dict[str, dict[int, list[float]]] = {}

    def add(label: str, N: int, value: float) -> None:
        table.setdefault(label, {}).setdefault(N, []).append(value)

    for i, train in logs.items():
        fitted = {
            label: fit_log(train, name, target="E", params=params, unit="um").saved for label, name, params in VARIANTS
        }
        for j, test in logs.items():
            if j == i:
                continue
            E = test.columns["E"]
            drifts = {label: predict_log(saved, test)[0] for label, saved in fitted.items()}
            for N in INTERVALS:
                add("no model", N, residual(E, None, N, "change"))
                for label, drift in drifts.items():
                    add(f"{label}: change since measured", N, residual(E, drift, N, "change"))
                for label, drift in drifts.items():
                    add(f"{label}: absolute drift", N, residual(E, drift, N, "absolute"))
    print(
        "gooddash: train on one run, apply to the 4 others (20 pairs); one correction every N samples from the "
        "report of the parts cut N samples before; RMS error left on the parts cut after the first correction, µm"
    )
    print(f"{'feed-forward':40s}" + "".join(f"{'N = ' + str(N):>10s}" for N in INTERVALS))
    seen = set()
    for label, by_n in table.items():
        if label in seen:
            continue
        seen.add(label)
        print(f"{label:40s}" + "".join(f"{np.mean(by_n[N]):10.2f}" for N in INTERVALS))
    return 0


if __name__ == "__main__":
    with threadpool_limits(1):
        raise SystemExit(main())
