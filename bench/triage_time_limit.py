"""Wall time of the exact solve against its time limit on triage problems (HiGHS bounded from outside).

Problems: the random multi-part fixtures of ``bench/exact_scaling.py`` with a normal error of
0.06 mm added to every deviation, so that most dimensions are out of reach and the triage MILPs
(most dimensions in tolerance, their error budget, the least norm) decide; these are the MILPs
whose RINS/RENS sub-searches ran past the limit.  Each is solved with a short limit; reported
are the wall time, the overrun beyond the limit, the status and the stage that stopped.  HiGHS
runs with its interrupt callbacks on the wall clock and without RINS/RENS
(:mod:`setupfix.optimize.exact.highs`).

    python -m bench.triage_time_limit             # 3 sizes x 3 seeds x limits 0.5 and 2 s
    python -m bench.triage_time_limit --seeds 1

Writes ``bench/results/triage_time_limit.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from bench.problems import shop_problem
from setupfix.optimize import CorrectionProblem, get_optimizer

RESULTS = ROOT / "bench" / "results"
SIZES = [(60, 400), (100, 800), (180, 2000)]


def triage_problem(n: int, m: int, seed: int) -> CorrectionProblem:
    p = shop_problem(n, m, seed)
    dev = p.deviation + np.round(np.random.default_rng(seed).normal(0.0, 0.06, m), 4)
    return CorrectionProblem(
        composite=p.composite,
        deviation=dev,
        lower=p.lower,
        upper=p.upper,
        lb=p.lb,
        ub=p.ub,
        resolution=p.resolution,
        register_ids=p.register_ids,
        dimension_ids=p.dimension_ids,
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--limits", type=float, nargs="+", default=[0.5, 2.0])
    parser.add_argument("--out", type=Path, default=RESULTS / "triage_time_limit.txt")
    args = parser.parse_args(argv)
    lines = [
        f"$ python -m bench.triage_time_limit {' '.join(argv if argv is not None else sys.argv[1:])}".rstrip(),
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
        f"{platform.python_version()}; load at start {os.getloadavg()[0]:.2f}",
        f"{'size':>11} {'seed':>4} {'limit':>5} {'wall s':>7} {'cpu s':>6} {'over s':>7} {'status':<11} "
        f"{'given up':>8}  stopped",
    ]
    print("\n".join(lines), flush=True)
    over: list[float] = []
    with threadpool_limits(limits=1):
        get_optimizer("exact").solve(triage_problem(10, 28, 99))  # warm-up
        for limit in args.limits:
            for n, m in SIZES:
                for seed in range(args.seeds):
                    problem = triage_problem(n, m, seed)
                    start, cpu = time.perf_counter(), time.process_time()
                    result = get_optimizer("exact", time_limit=limit).solve(problem)
                    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
                    over.append(wall - limit)
                    stopped = result.stopped
                    why = f"{stopped.stage}: {stopped.reason}" if stopped is not None else "-"
                    lines.append(
                        f"{n:>4} x {m:<5} {seed:>4} {limit:>5.1f} {wall:>7.3f} {cpu:>6.3f} "
                        f"{wall - limit:>+7.3f} {result.status:<11} {len(result.given_up or ()):>8}  "
                        f"{why[:90]}"
                    )
                    print(lines[-1], flush=True)
    lines += [
        "",
        f"overrun beyond the limit: max {max(over):+.3f} s, median {np.median(over):+.3f} s "
        f"over {len(over)} solves (wall clock; load at end {os.getloadavg()[0]:.2f})",
    ]
    print(lines[-1])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
