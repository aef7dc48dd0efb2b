"""`setupfix batch` throughput on N paper-size reports (the guide-pins cycles, 28 dimensions each).

Writes N distinct copies of the five bundled cycles (time stamps shifted so that no
two are duplicates) into a temporary folder and times the whole command, start-up
included, with 1 and 2 worker processes.  OpenBLAS/MKL threads are pinned to 1.
Reference timed in the same run: in-process ``correct_report`` (read + match + exact
solve + safety rules) on each of the five cycles, median of 5 runs each, averaged over
the cycles (the batch corrects them in equal shares), so the batch time per report is
also given as a ratio to it (1.0 = no per-report overhead beyond the work).  The exact
solver has a wall-clock limit (2 s): on a busy machine a solve may stop at it and
return a different (unproved) correction, so the 1- and 2-worker outputs are compared
and the differing rows counted.

    python bench/batch_throughput.py [--reports 1000]   # writes bench/results/batch_throughput.txt
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

from setupfix.model import load_model  # noqa: E402
from setupfix.pipeline.correct import correct_report  # noqa: E402

GUIDE = ROOT / "sample_reports" / "guide_pins"
OUT = ROOT / "bench" / "results" / "batch_throughput.txt"


def make_reports(folder: Path, n: int) -> None:
    texts = [(GUIDE / f"cycle_0{i}.csv").read_text() for i in range(1, 6)]
    for k in range(n):
        text = texts[k % 5].replace("T08:00:00", f"T{8 + (k // 3600) % 12:02d}:{(k // 60) % 60:02d}:{k % 60:02d}")
        (folder / f"r{k:05d}.csv").write_text(text)


def reference() -> float:
    model = load_model(GUIDE / "model.toml")
    per_cycle = []
    for i in range(1, 6):
        report = GUIDE / f"cycle_0{i}.csv"
        correct_report(model, report)
        times = []
        for _ in range(5):
            t = time.perf_counter()
            correct_report(model, report)
            times.append(time.perf_counter() - t)
        per_cycle.append(statistics.median(times))
    return statistics.mean(per_cycle)


def run(folder: Path, out: Path, workers: int) -> float:
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "setupfix", "batch", "--model", str(GUIDE / "model.toml"),
                           str(folder), "--out", str(out), "--settle", "0", "--workers", str(workers)],
                          cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(proc.stderr[-2000:])
    return seconds


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reports", type=int, default=1000)
    n = ap.parse_args().reports
    ref = reference()
    lines = [f"setupfix batch on {n} guide-pins reports (28 dimensions, 10 registers), start-up included; "
             "OPENBLAS/MKL/OMP threads = 1",
             f"reference: in-process correct_report (read + match + exact solve + rules), mean over the five "
             f"cycles of the median of 5: {ref * 1000:.1f} ms"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "reports"
        folder.mkdir()
        make_reports(folder, n)
        outs = []
        for workers in (1, 2):
            out = Path(tmp) / f"offsets_{workers}.csv"
            seconds = run(folder, out, workers)
            outs.append(out.read_bytes())
            per = seconds / n
            lines.append(f"workers {workers}: {seconds:.1f} s total, {per * 1000:.1f} ms per report "
                         f"= {per / ref:.2f}× the reference; {n / seconds:.0f} reports/s")
        a, b = outs[0].decode().splitlines(), outs[1].decode().splitlines()
        differing = sum(x != y for x, y in zip(a, b)) + abs(len(a) - len(b))
        lines.append(f"outputs of 1 and 2 workers: {'identical' if outs[0] == outs[1] else 'differ'} "
                     f"({differing} of {len(a) - 1} rows differ)")
        lines.append(f"target (issue 13): {n} reports in ≤ 10 s → {10 / n * 1000:.0f} ms per report")
    OUT.write_text("$ python bench/batch_throughput.py --reports %d\n" % n + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
