"""The leximin levels' grid climb: its move sizes (``ExactSettings.climb_scales``) against each other, in one process.

The climb (:mod:`setupfix.optimize.exact.leximin.search`) moves s·e_i and s·(±e_i ± e_j) with s from
``SCALES`` down to 1; it only gives the levels a start, so the answers must not depend on it.  The
box's speed drifts by more than a tenth between runs of ``bench/leximin_speed.py``, so the variants
are timed here in turns: every pass solves the 105 paper-size reports of ``leximin_speed.py`` once
per variant (each pass without the model's memo, as a new process), and each report's time is its
best pass.  The reference is one LP of eq. 8 per report, timed in the same run.  BLAS and HiGHS
single-threaded.

    python -m bench.climb_scales          # writes bench/results/climb_scales.txt
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

import numpy as np
from threadpoolctl import threadpool_limits

import setupfix.optimize.exact.session as session_mod
from bench.leximin_speed import lp_seconds
from bench.problems import guide_pins_problems
from setupfix.optimize import get_optimizer
from setupfix.optimize.exact import ExactSettings

RESULTS = ROOT / "bench" / "results"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", default="4/1,8/2/1", help="comma-separated SCALES, largest step first")
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--sets", type=int, default=100)
    ap.add_argument("--out", default=str(RESULTS / "climb_scales.txt"))
    args = ap.parse_args()
    variants = [tuple(float(s) for s in v.split("/")) for v in args.variants.split(",")]
    lines = [
        "The leximin levels' grid climb: move sizes against each other, interleaved in one process",
        f"command : python -m bench.{Path(__file__).stem} " + " ".join(sys.argv[1:]),
        f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"{os.cpu_count()} CPUs; BLAS 1 thread (threadpoolctl), HiGHS 1 thread",
        f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the start",
        f"reports : the {args.sets + 5} paper-size reports of bench/leximin_speed.py, objective leximin, 2 s "
        f"limit; {args.passes} passes, each solving every report once per variant in turn; each report's time "
        "its best",
    ]
    opts = [
        get_optimizer("exact", objective="leximin", time_limit=2.0, settings=ExactSettings(climb_scales=scales))
        for scales in variants
    ]
    opt = opts[0]
    with threadpool_limits(1):
        probs = guide_pins_problems(args.sets, 2014)
        lp = float(np.median([lp_seconds(p) for _, p in probs]))
        opt.solve(probs[0][1])  # warm-up (imports, first allocations)
        best = np.full((len(variants), len(probs)), np.inf)
        answers: list[list[np.ndarray]] = [[] for _ in variants]
        for _ in range(args.passes):
            for i, variant in enumerate(opts):
                session_mod.DERIVED.clear()
                for j, (_, p) in enumerate(probs):
                    began = time.perf_counter()
                    res = variant.solve(p)
                    best[i, j] = min(best[i, j], time.perf_counter() - began)
                    if len(answers[i]) < len(probs):
                        answers[i].append(np.asarray(res.x))
    lines.append(f"reference: one LP of eq. 8, median {lp * 1e3:.3f} ms")
    first = np.median(best[0])
    for i, scales in enumerate(variants):
        med = float(np.median(best[i]))
        same = sum(np.array_equal(a, b) for a, b in zip(answers[i], answers[0], strict=True))
        name = "/".join(f"{s:g}" for s in scales)
        lines.append(
            f"  SCALES {name:>8}: median {med * 1e3:.3f} ms = {med / lp:.2f}x LP = {med / first:.3f}x "
            f"the first; mean {np.mean(best[i]) * 1e3:.3f} ms; the same correction as the first on {same} "
            f"of {len(probs)}"
        )
    lines.append(f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the end")
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
