"""The test suite's fast subset against the whole suite: wall time, CPU time and test counts.

    python -m bench.suite_subsets [--out bench/results/suite_subsets.txt]

Runs ``pytest -q -n 2 -m "not slow"`` and then ``pytest -q -n 2`` (what ``.ci/run`` runs, less the
services it starts: the PostgreSQL tests skip without ``SETUPFIX_TEST_PG``), each as a process of its
own, and reports each time as a ratio to the whole suite's, timed in the same run, with the load
average beside it: the box is shared, so only the ratio travels.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "bench" / "results" / "suite_subsets.txt"


def run(args: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds (children included) of one pytest run, and its closing line."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "2", "-p", "no:cacheprovider", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = [ln for ln in done.stdout.splitlines() if re.search(r"\d+ (passed|failed)", ln)]
    return wall, cpu, lines[-1] if lines else f"exit {done.returncode}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    fast = run(["-m", "not slow"])
    whole = run([])
    lines = [
        "command : python -m bench.suite_subsets",
        f"load average at the start: {load:.1f} (2 cores)",
        f"{'run':<22s} {'wall [s]':>9s} {'ratio':>6s} {'cpu [s]':>8s} {'ratio':>6s}  result",
    ]
    for name, (wall, cpu, result) in (("-m 'not slow'", fast), ("whole suite", whole)):
        lines.append(f"{name:<22s} {wall:9.1f} {wall / whole[0]:6.2f} {cpu:8.1f} {cpu / whole[1]:6.2f}  {result}")
    text = "\n".join(lines) + "\n"
    args.out.write_text(text, encoding="utf-8")
    print(text, end="")


if __name__ == "__main__":
    main()
