"""A long batch in one process gives every report the answer it gets alone (issue 21, item 1).

Before issue 20's per-solve session, the HiGHS models kept across reports summed their run
clocks, so after a few thousand reports in one process every solve stopped at its limit and
the report read "hold". This bench writes ``--reports`` guide-pins reports, each with its own
deviations (``bench/batch_throughput.py --vary``: each actual moved by a seeded uniform step in
±0.005 mm), corrects them with ONE ``setupfix batch --workers 1`` process, and corrects each
report again *alone*: in a fresh forked process per report (a pool with ``maxtasksperchild=1``,
forked from a parent that has imported the solver's modules but solved nothing), through the same
use case (``correct_report``) and offsets policy (``cycle_rows``). Every offset row (report, part,
register, delta, verdict) is compared; the statuses of the lone solves are counted.

    python -m bench.batch_long_run                # 6,000 reports
    python -m bench.batch_long_run --reports 500

Writes ``bench/results/batch_long_run.txt``. Threads: OPENBLAS/MKL/OMP = 1, HiGHS 1 thread.
The reference timed in the same run is the in-process ``correct_report`` of
``bench/batch_throughput.py``; the batch's time per report is given as a ratio to it.
"""

from __future__ import annotations

import argparse
import csv
import functools
import multiprocessing as mp
import os
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

from bench.batch_throughput import reference, run
from bench.problems import GUIDE, make_reports
from setupfix.model import load_model
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import cycle_rows
from setupfix.usecases.requests import CorrectRequest, SolveOptions

RESULTS = ROOT / "bench" / "results"
#: Seconds each exact solve may take, on both sides. The question here is whether a long run changes an
#: answer, not the machine's speed: with the default 2 s, a busy box stops some solves at the limit on one
#: side and not the other (a stopped solve says so), which would be counted here as a difference.
LIMIT = 60.0
#: The limit of the re-check: every report whose rows differ is solved alone once more with this limit,
#: to tell a difference made by a solve stopped at LIMIT (on a loaded box) from a wrong answer.
RECHECK_LIMIT = 600.0
Key = tuple[str, str, str]


def alone(path: str, limit: float = LIMIT) -> tuple[str, list[tuple[Key, str, str]], list[str]]:
    """One report corrected in this (fresh) process: its offset rows and the solver statuses."""
    request = CorrectRequest(load_model(GUIDE / "model.toml"), solve=SolveOptions(time_limit=limit))
    outcome = correct_report(request, Path(path))
    rows, statuses = [], []
    for cycle in outcome.cycles:
        statuses.append(cycle.result.status)
        for row in cycle_rows(cycle):
            rows.append(((Path(path).name, row.part, row.id), f"{row.delta:.3f}", row.verdict))
    return path, rows, statuses


def warm_imports() -> None:
    """Import what one solve loads (HiGHS, SciPy, the optimiser modules) without solving anything, so
    that each forked child starts from loaded modules rather than paying the imports again."""
    import importlib
    import pkgutil

    import highspy  # noqa: F401
    import scipy.optimize
    import scipy.sparse  # noqa: F401
    import threadpoolctl  # noqa: F401

    import setupfix.optimize as optimize

    for info in pkgutil.iter_modules(optimize.__path__):
        importlib.import_module(f"setupfix.optimize.{info.name}")


def batch_statuses(db: Path) -> dict[str, list[str]]:
    """The batch's solver status of each report, from the recommendations it stored (``--store``)."""
    from setupfix.store import open_store

    out: dict[str, list[str]] = {}
    with open_store(str(db)) as store:
        for rec in store.recommendations():
            out.setdefault(Path(str(rec.inputs.get("report", ""))).name, []).append(str(rec.result.get("status")))
    return out


def _pair(first: dict[str, tuple[list[tuple[Key, str, str]], list[str]]], key: Key) -> tuple[str, str]:
    """The lone (delta, verdict) of one offset row."""
    return next((d, v) for k, d, v in first[key[0]][0] if k == key)


def batch_rows(out: Path) -> dict[Key, tuple[str, str]]:
    with out.open(newline="") as handle:
        return {
            (Path(r["report"]).name, r["part"], r["id"]): (f"{float(r['delta']):.3f}", r["verdict"])
            for r in csv.DictReader(handle)
        }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--reports", type=int, default=6000)
    ap.add_argument("--limit", type=float, default=LIMIT, help="time limit of every solve on both sides")
    args = ap.parse_args()
    n, limit = args.reports, args.limit
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "reports"
        folder.mkdir()
        make_reports(folder, n, vary=True)
        files = sorted(str(p) for p in folder.iterdir())
        warm_imports()
        ctx = mp.get_context("fork")
        t = time.perf_counter()
        with ctx.Pool(2, maxtasksperchild=1) as pool:  # forked before this process solves anything
            lone = pool.map(functools.partial(alone, limit=limit), files, chunksize=1)
        lone_seconds = time.perf_counter() - t
        out = Path(tmp) / "offsets.csv"
        db = Path(tmp) / "history.db"  # the batch's own statuses: which of its solves stopped at the limit
        seconds = run(folder, out, 1, extra=("--time-limit", str(limit), "--store", str(db)))
        batch_status = batch_statuses(db)
        ref = reference()
        got = batch_rows(out)
        first = {Path(path).name: (rows, stats) for path, rows, stats in lone}
        differing = sorted(
            {k[0] for k, _, _ in (r for _, rows, _ in lone for r in rows) if got.get(k) != (_pair(first, k))}
        )
        with ctx.Pool(2, maxtasksperchild=1) as pool:  # each differing report alone again, with a long limit
            again = pool.map(
                functools.partial(alone, limit=RECHECK_LIMIT), [str(folder / name) for name in differing], chunksize=1
            )
    statuses: Counter[str] = Counter()
    expected: dict[Key, tuple[str, str]] = {}
    for _, rows, stats in lone:
        statuses.update(stats)
        expected.update({key: (delta, verdict) for key, delta, verdict in rows})
    differ = [k for k in expected if got.get(k) != expected[k]]
    stopped_alone = [r for r in differing if any(st != "optimal" for st in first[r][1])]
    proved_again = {Path(path).name: (rows, stats) for path, rows, stats in again}
    batch_right = [
        r
        for r in differing
        if all(st == "optimal" for st in proved_again[r][1])
        and all(got.get(k) == (d, v) for k, d, v in proved_again[r][0])
    ]
    # what is left: the recheck not proved (a 600 s limit on a loaded box), the batch's own solve stopped at
    # its limit (its answer is then the best found, said so by its status), or both proved and different
    not_proved = [r for r in differing if r not in batch_right and any(st != "optimal" for st in proved_again[r][1])]
    batch_stopped = [
        r
        for r in differing
        if r not in batch_right
        and r not in not_proved
        and any(st != "optimal" for st in batch_status.get(r, ["missing"]))
    ]
    wrong = [r for r in differing if r not in batch_right + not_proved + batch_stopped]
    missing_reports = {k[0] for k in expected} - {k[0] for k in got}
    first_bad = min((int(k[0][1:6]) for k in differ), default=None)
    lines = [
        f"$ python -m bench.batch_long_run --reports {n}",
        f"{n} guide-pins reports (28 dimensions, 10 registers), each with its own deviations; "
        f"OPENBLAS/MKL/OMP threads = 1, HiGHS 1 thread; machine: busy 2-core box; time limit {limit:g} s per "
        "solve on both sides",
        f"batch, one process, --workers 1: {seconds:.1f} s = {seconds / n * 1000:.2f} ms per report "
        f"= {seconds / n / ref:.2f}× the reference (in-process correct_report, {ref * 1000:.2f} ms)",
        f"alone (a fresh forked process per report, 2 at a time): {lone_seconds:.1f} s; "
        f"statuses {dict(sorted(statuses.items()))}",
        f"offset rows compared: {len(expected)}; differing: {len(differ)}; reports missing from the batch: "
        f"{len(missing_reports)}" + (f"; first differing report r{first_bad:05d}" if differ else ""),
        f"reports with differing rows: {len(differing)}; of them, the lone solve stopped at the {limit:g} s limit: "
        f"{len(stopped_alone)}; solved alone again with a {RECHECK_LIMIT:g} s limit: proved and equal to the batch "
        f"in {len(batch_right)}",
        f"of the rest: recheck not proved {len(not_proved)}, the batch's own solve stopped at its limit "
        f"{len(batch_stopped)}, both proved and different {len(wrong)}"
        + (f" ({', '.join(wrong[:10])})" if wrong else ""),
        "verdict: "
        + (
            "every report gets exactly the answer it gets alone"
            if not differ and not missing_reports
            else "every difference is a lone solve stopped at its limit: the batch equals the proved answer"
            if not missing_reports and len(batch_right) == len(differing) == len(stopped_alone)
            else "every difference is a solve stopped at its limit (alone or in the batch, each said so by its "
            "status): no proved answer differs"
            if not missing_reports and not wrong
            else "DIFFERENT ANSWERS"
        ),
    ]
    (RESULTS / "batch_long_run.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
