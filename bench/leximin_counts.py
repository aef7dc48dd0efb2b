"""Leximin count MILPs with and without HiGHS's presolve (issue 22: the batch's long tail).

The varied guide-pins reports of ``bench/batch_throughput.py --vary`` (each actual moved by a
seeded step in ±0.005 mm) are corrected once; those whose leximin reaches the counts
(:mod:`setupfix.optimize._leximin_counts`, a discrete conflict that branches cannot decide) are
then corrected again, alternately with the count MILPs presolved (HiGHS's default) and not
(:meth:`~setupfix.optimize._highs.LinearModel.skip_presolve`, what the optimiser does), twice
each.  Time is process CPU time (the box is shared; wall time would measure the load), given
per report and as a ratio to the in-process reference of the same run (the mean over the five
bundled cycles of ``correct_report``).  The corrections must be identical where both are proved.

    python bench/leximin_counts.py                 # 300 reports, 60 s limit
    python bench/leximin_counts.py --reports 100

Threads: OPENBLAS/MKL/OMP = 1, HiGHS 1 thread.  Writes ``bench/results/leximin_counts.txt``.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

import numpy as np
from batch_throughput import GUIDE, make_reports, reference

from setupfix.model import load_model
from setupfix.optimize._highs import LinearModel
from setupfix.pipeline.correct import correct_report
from setupfix.pipeline.requests import CorrectRequest, SolveOptions

RESULTS = ROOT / "bench" / "results"
SKIP = LinearModel.skip_presolve


def presolve(on: bool) -> None:
    """Count MILPs presolved (HiGHS's default) or not (the optimiser's setting)."""
    LinearModel.skip_presolve = (lambda self: None) if on else SKIP  # type: ignore[method-assign]


def solve(request: CorrectRequest, path: Path) -> tuple[float, str, str, np.ndarray]:
    t = time.process_time()
    outcome = correct_report(request, path)
    cpu = time.process_time() - t
    result = outcome.cycles[0].result
    return cpu, result.status, str(result.extra.get("path", "")), np.round(result.x, 9)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reports", type=int, default=300)
    ap.add_argument("--limit", type=float, default=60.0)
    args = ap.parse_args()
    request = CorrectRequest(load_model(GUIDE / "model.toml"), solve=SolveOptions(time_limit=args.limit))
    load0 = os.getloadavg()[0]
    ref = reference()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        make_reports(folder, args.reports, vary=True)
        files = sorted(folder.glob("*.csv"))
        presolve(False)
        counted = [f for f in files if "the rest by counts" in solve(request, f)[2]]
        rows = []
        for f in counted:
            runs: dict[bool, list[tuple[float, str, np.ndarray]]] = {True: [], False: []}
            for _ in range(2):
                for on in (True, False):
                    presolve(on)
                    cpu, status, _, x = solve(request, f)
                    runs[on].append((cpu, status, x))
            rows.append((f.name, runs))
        presolve(False)
    lines = [
        "Leximin count MILPs: HiGHS presolve on (default) vs off (the optimiser's setting), process CPU time",
        f"command : python bench/leximin_counts.py --reports {args.reports} --limit {args.limit:g}",
        "threads : OPENBLAS/MKL/OMP = 1, HiGHS threads = 1",
        f"load    : 1-min load average {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at the end",
        f"reference: in-process correct_report of the five bundled cycles, mean {ref * 1e3:.2f} ms (wall)",
        f"reports : {args.reports} varied guide-pins reports; {len(counted)} reach the counts",
        "",
        f"{'report':<12}{'on: CPU s':>11}{'off: CPU s':>12}{'on/off':>8}  {'status on/off':<24}same",
    ]
    ratios = []
    for name, runs in rows:
        on = min(c for c, _, _ in runs[True])
        off = min(c for c, _, _ in runs[False])
        s_on, s_off = runs[True][0][1], runs[False][0][1]
        proved = s_on == "optimal" and s_off == "optimal"
        same = np.array_equal(runs[True][0][2], runs[False][0][2]) if proved else None
        if proved:
            ratios.append(on / off)
        lines.append(f"{name:<12}{on:>11.2f}{off:>12.2f}{on / off:>8.2f}  {s_on + '/' + s_off:<24}"
                     f"{'yes' if same else 'NO' if same is False else '- (stopped: not compared)'}")
    if ratios:
        lines += ["", f"proved on both sides: {len(ratios)}; CPU on/off median {np.median(ratios):.2f}x, "
                      f"min {min(ratios):.2f}x, max {max(ratios):.2f}x"]
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "leximin_counts.txt").write_text(text)
    print(text, end="")


if __name__ == "__main__":
    main()
