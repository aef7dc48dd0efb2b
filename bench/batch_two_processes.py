"""Two batch processes on one history store give every report its own answer, once (issue 37).

Writes ``--reports`` guide-pins reports, each with its own deviations (:func:`bench.problems.make_reports`
with ``vary``), and corrects them three ways:

1. the reference: one ``setupfix batch`` without a store (``bench/batch_long_run.py`` shows that this
   equals each report corrected alone);
2. two ``setupfix batch --store`` processes started together on the same folder and the same SQLite
   store, each writing its own offsets CSV;
3. the same two again: the store now holds every report, so neither corrects anything.

Checked: each report is corrected by exactly one of the two processes; the union of their rows equals
the reference row for row (register, delta, verdict); the store holds each report once with one
recommendation per part; the second pass corrects nothing. The wall time of the two processes is given
as a ratio to the reference batch timed in the same run.

    python -m bench.batch_two_processes                # 2,000 reports
    python -m bench.batch_two_processes --reports 300

Writes ``bench/results/batch_two_processes.txt``. Threads: OPENBLAS/MKL/OMP = 1.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

from bench.problems import GUIDE, make_reports
from setupfix.store import open_store

RESULTS = ROOT / "bench" / "results"
Key = tuple[str, str, str]


def command(folder: Path, out: Path, *extra: str) -> list[str]:
    """``setupfix batch`` on ``folder`` with one worker (the two processes are the parallelism here)."""
    model = str(GUIDE / "model.toml")
    return [
        *(sys.executable, "-m", "setupfix", "batch", "--model", model, str(folder), "--out", str(out)),
        *("--settle", "0", "--workers", "1", *extra),
    ]


def rows(out: Path) -> dict[Key, tuple[str, str]]:
    """Offset rows of one CSV: (report, part, register ID) → (delta, verdict); none when nothing was written."""
    if not out.exists():
        return {}
    with out.open(newline="") as handle:
        return {
            (Path(r["report"]).name, r["part"], r["id"]): (f"{float(r['delta']):.4f}", r["verdict"])
            for r in csv.DictReader(handle)
        }


def together(folder: Path, db: Path, outs: tuple[Path, Path]) -> tuple[float, list[int]]:
    """Both store-sharing batches started at once: wall seconds and exit codes."""
    t = time.perf_counter()
    procs = [
        subprocess.Popen(
            command(folder, out, "--store", str(db)),
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for out in outs
    ]
    codes = []
    for p in procs:
        _, err = p.communicate()
        if p.returncode not in (0, 6):
            raise SystemExit(f"batch failed ({p.returncode}): {err[-2000:]}")
        codes.append(p.returncode)
    return time.perf_counter() - t, codes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reports", type=int, default=2000)
    n = ap.parse_args().reports
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        folder = base / "reports"
        folder.mkdir()
        make_reports(folder, n, vary=True)
        t = time.perf_counter()
        subprocess.run(command(folder, base / "reference.csv"), cwd=ROOT, check=False, capture_output=True)
        reference_s = time.perf_counter() - t
        expected = rows(base / "reference.csv")
        db = base / "history.db"
        outs = (base / "a.csv", base / "b.csv")
        two_s, codes = together(folder, db, outs)
        got_a, got_b = rows(outs[0]), rows(outs[1])
        reports_a, reports_b = {k[0] for k in got_a}, {k[0] for k in got_b}
        union = {**got_a, **got_b}
        differing = [k for k in expected if union.get(k) != expected[k]]
        extra_rows = [k for k in union if k not in expected]
        with open_store(db) as store:
            stored = store.reports()
            recommendations = store.recommendations()
        per_report = {r.name for r in stored}
        parts = len({(k[0], k[1]) for k in expected})
        again = (base / "a2.csv", base / "b2.csv")
        _, _ = together(folder, db, again)
        corrected_again = len({k[0] for k in rows(again[0])} | {k[0] for k in rows(again[1])})
    lines = [
        f"$ python -m bench.batch_two_processes --reports {n}",
        f"{n} guide-pins reports (28 dimensions, 10 registers), each with its own deviations; two `setupfix batch "
        "--store` processes (--workers 1 each) started together on one folder and one SQLite store; "
        "OPENBLAS/MKL/OMP threads = 1; machine: busy 2-core box",
        f"reference, one batch without a store: {reference_s:.1f} s; the two together: {two_s:.1f} s = "
        f"{two_s / reference_s:.2f}× the reference; exit codes {codes}",
        f"reports corrected: first process {len(reports_a)}, second {len(reports_b)}, by both "
        f"{len(reports_a & reports_b)}, by neither {n - len(reports_a | reports_b)}",
        f"offset rows compared with the reference: {len(expected)}; differing: {len(differing)}; rows the "
        f"reference lacks: {len(extra_rows)}",
        f"store: {len(stored)} reports ({len(per_report)} distinct names), {len(recommendations)} recommendations "
        f"for {parts} parts",
        f"second pass of both processes: reports corrected again {corrected_again}",
        "verdict: "
        + (
            "every report corrected once, with the answer it gets alone, and stored once"
            if not differing
            and not extra_rows
            and not (reports_a & reports_b)
            and len(reports_a | reports_b) == n
            and len(stored) == n
            and len(recommendations) == parts
            and corrected_again == 0
            else "DIFFERENT"
        ),
    ]
    (RESULTS / "batch_two_processes.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
