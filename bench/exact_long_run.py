"""A long run of the exact optimiser in one process: every report gets the answer of a fresh process.

Issue 21, item 1: HiGHS adds up the run time of every run of one solver object and compares
its time limit with that sum, so models kept across reports ran out of time after a few
thousand reports (2 s default limit) and every later solve stopped at once.  This bench
solves ``--reports`` guide-pins reports (random sets by eqs. 12-13, drawn once and solved
in turn) with one optimiser instance at the default limit, and compares each answer with
the one a fresh process gives (a subprocess solving each distinct set once).

    python -m bench.exact_long_run                 # 6,000 reports, 50 distinct sets
    python -m bench.exact_long_run --reports 1000

Writes ``bench/results/exact_long_run.txt`` (with the command).  The time per report is
given as a ratio to one vectorised ``problem.evaluate`` of 5,000 grid solutions (the
reference of ``bench/exact_per_report.py``), timed in the same run; BLAS single-threaded.
"""

from __future__ import annotations

import argparse
import os
import pickle
import platform
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from setupfix.correction.synthetic import simulate_deviations
from setupfix.model import PartMeasurement, load_model
from setupfix.optimize import CorrectionProblem, get_optimizer

#: The allocator pinned as in bench/exact_per_report.py (the reference's page faults otherwise depend on
#: what the process freed before); Linux only, the bench re-executes itself with them.
MALLOC = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(64 << 20)}

FRESH = """
import pickle, sys
from setupfix.optimize import get_optimizer
out = [get_optimizer("exact").solve(p) for p in pickle.load(open(sys.argv[1], "rb"))]
pickle.dump([(r.x, r.status) for r in out], open(sys.argv[2], "wb"))
"""


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reports", type=int, default=6000)
    parser.add_argument("--sets", type=int, default=50, help="distinct measurement sets, solved in turn")
    parser.add_argument("--seed", type=int, default=2014)
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "exact_long_run.txt")
    args = parser.parse_args(argv)
    model = load_model(ROOT / "sample_reports" / "guide_pins" / "model.toml")
    devs, _ = simulate_deviations(model, args.sets, w1=0.03, w2=0.02, seed=args.seed)
    problems = [
        CorrectionProblem.from_part(model, PartMeasurement(f"set {i + 1}", "eqs. 12-13", None, d, ("",) * d.size))
        for i, d in enumerate(devs)
    ]
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "p.pkl", Path(tmp) / "a.pkl"
        src.write_bytes(pickle.dumps(problems))
        subprocess.run(
            [sys.executable, "-c", FRESH, str(src), str(dst)],
            check=True,
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
        fresh = pickle.loads(dst.read_bytes())
    optimizer = get_optimizer("exact")
    rng = np.random.default_rng(0)
    limits = threadpool_limits(limits=1)  # BLAS single-threaded for the reference too, as in exact_per_report
    statuses: Counter[str] = Counter()
    differ, first_stop, times, refs = 0, None, [], []
    wall = time.perf_counter()
    for n in range(args.reports):
        i = n % len(problems)
        if n % 100 == 0:
            p = problems[i]
            x_ref = p.snap(rng.uniform(p.lb, p.ub, (5000, p.n_registers)))
            p.evaluate(x_ref)
            start = time.perf_counter()
            p.evaluate(x_ref)
            refs.append(time.perf_counter() - start)
        start = time.perf_counter()
        result = optimizer.solve(problems[i])
        times.append(time.perf_counter() - start)
        statuses[result.status] += 1
        if result.status != "optimal" and first_stop is None:
            first_stop = n + 1
        differ += not np.array_equal(result.x, fresh[i][0])
    wall = time.perf_counter() - wall
    limits.unregister()
    t, ref = np.array(times), float(np.median(refs))
    lines = [
        "Exact optimiser: a long run in one process against a fresh process (issue 21, item 1)",
        f"command : python -m bench.exact_long_run --reports {args.reports} --sets {args.sets} --seed {args.seed}",
        (
            f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
            f"wall time {wall:.1f} s; 1-min load average {os.getloadavg()[0]:.2f} at the end ({os.cpu_count()} cores)"
        ),
        (
            f"reports : {args.reports} in one process, one optimiser instance, default time limit; "
            f"{args.sets} distinct sets (eqs. 12-13, seed {args.seed}) in turn"
        ),
        f"fresh   : statuses of the distinct sets in a fresh process {dict(Counter(s for _, s in fresh))}",
        f"status  : {dict(statuses)}; first report not optimal: {first_stop or 'none'}",
        f"answers : {differ} of {args.reports} differ from the fresh process's",
        (
            f"time    : median {np.median(t) * 1e3:.2f} ms = {np.median(t) / ref:.2f}x reference "
            f"({ref * 1e3:.3f} ms); last 500 reports median {np.median(t[-500:]) * 1e3:.2f} ms"
        ),
    ]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    if platform.system() == "Linux" and any(os.environ.get(k) != v for k, v in MALLOC.items()):
        os.execve(
            sys.executable, [sys.executable, "-m", "bench.exact_long_run", *sys.argv[1:]], {**os.environ, **MALLOC}
        )
    main()
