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

Where the time goes: the command on a folder of one report (start-up: imports, model,
one report), and the batch's own per-report stages run in this process over the first
``--stages`` reports (wall clock, mean per report): reading the file and hashing it,
reading the report (sniffing, parsing, the canonical table), matching it to the model
and checking it, correcting it (exact solve and safety rules), and its offset rows.

``--vary`` gives every copy its own deviations (each actual moved by a seeded uniform
step in ±0.005 mm, the stated deviation recomputed), so that no two reports pose the
same problem to the solver; without it the copies repeat five problems.

    python -m bench.batch_throughput [--reports 1000] [--vary]   # writes bench/results/batch_throughput[_vary].txt
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

import parsers
from bench.problems import GUIDE, make_reports
from setupfix.inputs.checks import check_parts
from setupfix.inputs.cycles import assign_stations
from setupfix.model import load_model, match_parts
from setupfix.usecases.correct import correct_cycle, correct_report
from setupfix.usecases.export import cycle_rows
from setupfix.usecases.requests import CorrectRequest

RESULTS = ROOT / "bench" / "results"


def reference() -> float:
    request = CorrectRequest(load_model(GUIDE / "model.toml"))
    per_cycle = []
    for i in range(1, 6):
        report = GUIDE / f"cycle_0{i}.csv"
        correct_report(request, report)
        times = []
        for _ in range(5):
            t = time.perf_counter()
            correct_report(request, report)
            times.append(time.perf_counter() - t)
        per_cycle.append(statistics.median(times))
    return statistics.mean(per_cycle)


def stages(files: list[Path]) -> dict[str, float]:
    """Mean seconds per report of each stage of the batch's per-report work, in this process."""
    model = load_model(GUIDE / "model.toml")
    request = CorrectRequest(model)
    total = dict.fromkeys(("file + hash", "read", "match + check", "correct", "offset rows"), 0.0)
    for path in files:
        t0 = time.perf_counter()
        source = parsers.load_source(path)
        hashlib.sha256(source.data).hexdigest()
        t1 = time.perf_counter()
        table = parsers.read_report(source).table
        t2 = time.perf_counter()
        parts = check_parts(
            model, match_parts(model, assign_stations(model, table), source=str(path)), source=str(path)
        )
        t3 = time.perf_counter()
        results = [correct_cycle(request, part) for part in parts]
        t4 = time.perf_counter()
        [cycle_rows(r) for r in results]
        t5 = time.perf_counter()
        for key, seconds in zip(total, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4), strict=True):
            total[key] += seconds
    return {key: seconds / len(files) for key, seconds in total.items()}


def run(folder: Path, out: Path, workers: int, tree: Path = ROOT, extra: tuple[str, ...] = ()) -> float:
    """Wall seconds of ``setupfix batch`` (the package of ``tree``) on ``folder``, as a whole process."""
    t = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "setupfix",
            "batch",
            "--model",
            str(GUIDE / "model.toml"),
            str(folder),
            "--out",
            str(out),
            "--settle",
            "0",
            "--workers",
            str(workers),
            *extra,
        ],
        cwd=tree,
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"{tree}: {proc.stderr[-2000:]}")
    return seconds


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reports", type=int, default=1000)
    ap.add_argument("--stages", type=int, default=200, help="reports timed stage by stage in process")
    ap.add_argument("--vary", action="store_true", help="every report with its own deviations")
    args = ap.parse_args()
    n = args.reports
    ref = reference()
    kind = "varied copies (own deviations)" if args.vary else "copies repeating five problems"
    lines = [
        f"setupfix batch on {n} guide-pins reports (28 dimensions, 10 registers; {kind}), start-up "
        "included; OPENBLAS/MKL/OMP threads = 1, HiGHS threads = 1",
        f"reference: in-process correct_report (read + match + exact solve + rules), mean over the five "
        f"cycles of the median of 5: {ref * 1000:.1f} ms",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "reports"
        folder.mkdir()
        make_reports(folder, n, args.vary)
        files = sorted(folder.iterdir())
        one = Path(tmp) / "one"
        one.mkdir()
        (one / files[0].name).write_bytes(files[0].read_bytes())
        startup = statistics.median(run(one, Path(tmp) / "one.csv", 1) for _ in range(3))
        lines.append(
            f"start-up: the command on a folder of one report, median of 3: {startup:.2f} s "
            f"= {startup / ref:.0f}× the reference"
        )
        per = stages(files[: args.stages])
        shown = ", ".join(f"{k} {v * 1000:.2f} ms ({v / ref:.2f})" for k, v in per.items())
        lines.append(
            f"per report in process, mean over {min(args.stages, n)} of these reports (× the reference): "
            f"{shown}; sum {sum(per.values()) * 1000:.2f} ms ({sum(per.values()) / ref:.2f})"
        )
        outs, totals = [], {}
        for workers in (1, 2):
            out = Path(tmp) / f"offsets_{workers}.csv"
            seconds = totals[workers] = run(folder, out, workers)
            outs.append(out.read_bytes())
            per_report = seconds / n
            lines.append(
                f"workers {workers}: {seconds:.1f} s total, {per_report * 1000:.1f} ms per report "
                f"= {per_report / ref:.2f}× the reference; {n / seconds:.0f} reports/s; after start-up "
                f"{(seconds - startup) / n * 1000:.1f} ms per report"
            )
        a, b = outs[0].decode().splitlines(), outs[1].decode().splitlines()
        differing = sum(x != y for x, y in zip(a, b, strict=False)) + abs(len(a) - len(b))
        lines.append(
            f"outputs of 1 and 2 workers: {'identical' if outs[0] == outs[1] else 'differ'} "
            f"({differing} of {len(a) - 1} rows differ)"
        )
        verdicts = [
            f"{w} worker{'s' if w > 1 else ''} {'met' if t / n <= 0.010 else 'MISSED'} "
            f"({t / n * 1000:.1f} ms per report)"
            for w, t in totals.items()
        ]
        lines.append("target (issues 15 and 22): 1,000 reports in ≤ 10 s → 10 ms per report: " + "; ".join(verdicts))
    suffix = "_vary" if args.vary else ""
    command = f"$ python -m bench.batch_throughput --reports {n}" + (" --vary" if args.vary else "")
    (RESULTS / f"batch_throughput{suffix}.txt").write_text(command + "\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
