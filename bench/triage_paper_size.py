"""Triage at paper size: time per report when one or two dimensions are grossly out, before and after.

Problems: the five bundled guide-pins cycles (10 registers x 28 dimensions, the paper's example),
each with one or two dimensions (random, seeded) set grossly out of tolerance: a deviation of
random sign and size 0.2-0.4 mm on the +-0.1 mm tolerance (as cycle_01 with P1 D1 at -0.25 mm).
Every report is solved by the exact optimiser (default objective, leximin; time limit 2 s), and
one LP of eq. 8 on the same report (the optimiser's HiGHS interface, a fresh session) is timed
just before it: every time is also given as a ratio to the median LP of the same run.

"before" is the code the triage speed-up started from (a git worktree of ``--before-commit``),
"after" this checkout; each runs in its own subprocess (BLAS limited to 1 thread, HiGHS threads 1,
the allocator pinned as in ``bench/exact_per_report.py``), on the same reports.  Per version:
median, p95 and max wall time per report (all reports and triage cases alone), the triage stage's
own time, the statuses, how many leximins were complete, and which triage path ran.  With
``--check``, cycle_01 with P1 D1 at -0.25 mm is also solved by the MILP path alone (the forced
kept set switched off) with a long limit, and its correction compared with the default's.

    python -m bench.triage_paper_size                      # 60 reports, before and after
    python -m bench.triage_paper_size --reports 20 --no-before

Writes ``bench/results/triage_paper_size.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
MALLOC = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(64 << 20)}
#: The commit the triage speed-up (issue 22, forced kept set) started from.
BEFORE = "933f99e"


def reports(n: int, seed: int) -> list[tuple[str, np.ndarray]]:
    """(label, deviation) of n reports: cycles 1-5 in turn, each with 1 or 2 gross dimensions."""
    from setupfix.inputs.cycles import load_parts
    from setupfix.model import load_model

    sample = ROOT / "sample_reports" / "guide_pins"
    model = load_model(sample / "model.toml")
    base = [load_parts(model, sample / f"cycle_{i:02d}.csv")[0].deviation for i in range(1, 6)]
    rng = np.random.default_rng(seed)
    out = []
    for r in range(n):
        dev = base[r % 5].copy()
        gross = rng.choice(dev.size, size=1 + r % 2, replace=False)
        dev[gross] = rng.choice([-1.0, 1.0], gross.size) * np.round(rng.uniform(0.2, 0.4, gross.size), 3)
        out.append((f"cycle_{r % 5 + 1:02d} gross {','.join(map(str, gross))}", dev))
    return out


def worker(n: int, seed: int, limit: float) -> dict[str, object]:
    """Time every report in this process (the code on its PYTHONPATH); returns the raw numbers."""
    from threadpoolctl import threadpool_limits

    from setupfix.model import PartMeasurement, load_model
    from setupfix.optimize import CorrectionProblem, get_optimizer
    from setupfix.optimize.exact import ExactSettings
    from setupfix.optimize.exact.lp_bound import lp_bound, margin_rows
    from setupfix.optimize.exact.session import GridRows, Session

    model = load_model(ROOT / "sample_reports" / "guide_pins" / "model.toml")

    def problem_of(dev: np.ndarray) -> CorrectionProblem:
        return CorrectionProblem.from_part(model, PartMeasurement("c", "r", None, dev, ("",) * dev.size))

    def lp_seconds(problem: CorrectionProblem) -> float:
        free = problem.free
        g_rows, g = margin_rows(problem)
        t = time.perf_counter()
        rows = GridRows(
            g_rows, g, problem.kmin[free].astype(float), problem.kmax[free].astype(float), problem.cost[free]
        )
        lp_bound(Session(rows, ExactSettings(), 60.0))
        return time.perf_counter() - t

    out: dict[str, list[object]] = {
        k: [] for k in ("lp", "solve", "triage", "status", "triage_case", "complete", "forced", "given_up", "x")
    }
    with threadpool_limits(limits=1):
        items = reports(n, seed)
        opt = get_optimizer("exact", time_limit=limit)
        opt.solve(problem_of(items[0][1]))  # warm-up: imports, first HiGHS object
        for _, dev in items:
            problem = problem_of(dev)
            out["lp"].append(lp_seconds(problem))
            t = time.perf_counter()
            result = opt.solve(problem)
            out["solve"].append(time.perf_counter() - t)
            stages = dict(result.stages)
            tri = result.triage
            out["triage"].append(float(stages.get("triage", 0.0)))
            out["status"].append(result.status)
            out["triage_case"].append(tri is not None)
            out["complete"].append(tri.leximin_complete if tri is not None else None)
            out["forced"].append("kept set forced" in result.path)
            out["given_up"].append(len(result.given_up))
            out["x"].append([float(v) for v in result.x])
    return out


def check(limit: float) -> list[str]:
    """cycle_01, P1 D1 at -0.25 mm: the default answer against the MILP path alone with a long limit."""
    from setupfix.inputs.cycles import load_parts
    from setupfix.model import PartMeasurement, load_model
    from setupfix.optimize import CorrectionProblem, get_optimizer
    from setupfix.optimize.exact import ExactSettings

    sample = ROOT / "sample_reports" / "guide_pins"
    model = load_model(sample / "model.toml")
    (part,) = load_parts(model, sample / "cycle_01.csv")
    dev = part.deviation.copy()
    dev[0] = -0.25
    problem = CorrectionProblem.from_part(model, PartMeasurement("c", "r", None, dev, part.sources))
    fast = get_optimizer("exact").solve(problem)
    milp_path = ExactSettings(forced_triage=False, triage_leximin_share=0.9)
    t = time.perf_counter()
    slow = get_optimizer("exact", time_limit=limit, settings=milp_path).solve(problem)
    sec = time.perf_counter() - t
    same = np.array_equal(fast.x, slow.x)
    complete = slow.triage is not None and slow.triage.leximin_complete
    gap = float(np.max(np.abs(np.sort(problem.margins(fast.x)) - np.sort(problem.margins(slow.x)))))
    return [
        "",
        f"check: cycle_01, P1 D1 at -0.25 mm; MILP path alone (forced kept set off), limit {limit:g} s: "
        f"{sec:.1f} s, status {slow.status}, leximin complete {complete}",
        f"  default: {fast.seconds * 1e3:.1f} ms, status {fast.status}; same correction: {same}; largest "
        f"difference of the sorted margins {gap:.2e} mm",
    ]


def run(code: Path, n: int, seed: int, limit: float) -> dict[str, list[object]]:
    env = {**os.environ, **MALLOC, "PYTHONPATH": str(code), "OMP_NUM_THREADS": "1"}
    cmd = [
        sys.executable,
        str(Path(__file__).resolve()),
        "--worker",
        "--reports",
        str(n),
        "--seed",
        str(seed),
        "--limit",
        str(limit),
    ]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    data: dict[str, list[object]] = json.loads(out.stdout.strip().splitlines()[-1])
    return data


def summary(name: str, d: dict[str, list[object]]) -> list[str]:
    lp = np.array(d["lp"], dtype=float)
    ref = float(np.median(lp))
    solve = np.array(d["solve"], dtype=float)
    tri = np.array(d["triage_case"], dtype=bool)
    stage = np.array(d["triage"], dtype=float)
    statuses: dict[str, int] = {}
    for s in d["status"]:
        statuses[str(s)] = statuses.get(str(s), 0) + 1
    complete = sum(1 for c, t in zip(d["complete"], tri, strict=True) if t and c)
    forced = int(np.sum(np.array(d["forced"], dtype=bool) & tri))

    def row(label: str, t: np.ndarray) -> str:
        if t.size == 0:
            return f"  {label:22s} -"
        return (
            f"  {label:22s} median {np.median(t) * 1e3:8.2f} ms = {np.median(t) / ref:7.1f}x LP; "
            f"p95 {np.percentile(t, 95) * 1e3:8.2f} ms; max {t.max() * 1e3:8.1f} ms"
        )

    return [
        f"{name}: reference one LP of eq. 8, median {ref * 1e3:.3f} ms",
        row("solve, all reports", solve),
        row("solve, triage cases", solve[tri]),
        row("triage stage", stage[tri]),
        f"  {int(tri.sum())} triage cases of {tri.size}; status {statuses}; leximin complete in {complete} "
        f"of {int(tri.sum())}; forced kept set in {forced} of {int(tri.sum())}",
    ]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reports", type=int, default=60)
    ap.add_argument("--seed", type=int, default=22)
    ap.add_argument("--limit", type=float, default=2.0, help="time limit per report [s]")
    ap.add_argument("--before-commit", default=BEFORE)
    ap.add_argument("--no-before", action="store_true")
    ap.add_argument("--check", type=float, default=0.0, help="limit of the MILP-path check [s] (0: none)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.reports, args.seed, args.limit)))
        return
    lines = [
        "Triage at paper size: guide-pins cycles with 1 or 2 gross dimensions (exact optimiser, leximin)",
        "command : python -m bench.triage_paper_size " + " ".join(sys.argv[1:] if argv is None else argv),
        f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"{os.cpu_count()} CPUs",
        "threads : BLAS limited to 1 (threadpoolctl); HiGHS threads = 1; one subprocess per version",
        f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the start",
        f"reports : {args.reports} (cycles 1-5 in turn, 1 or 2 random dimensions at +-0.2-0.4 mm, seed "
        f"{args.seed}), time limit {args.limit:g} s",
        "",
    ]
    after = run(ROOT, args.reports, args.seed, args.limit)
    before = None
    if not args.no_before:
        tmp = Path("/tmp") / f"triage_before_{args.before_commit}"
        if not tmp.exists():
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tmp), args.before_commit],
                check=True,
                capture_output=True,
            )
        try:
            before = run(tmp, args.reports, args.seed, args.limit)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tmp)], capture_output=True)
        lines += [*summary(f"before ({args.before_commit})", before), ""]
    lines += summary("after (this checkout)", after)
    if before is not None:
        tri = np.array(after["triage_case"], dtype=bool) & np.array(before["triage_case"], dtype=bool)
        same = sum(1 for a, b, t in zip(after["x"], before["x"], tri, strict=True) if t and a == b)
        ratio = (
            np.median(np.array(before["solve"], dtype=float)[tri])
            / np.median(np.array(after["solve"], dtype=float)[tri])
            if tri.any()
            else float("nan")
        )
        lines += [
            "",
            f"triage cases: median solve time before / after = {ratio:.1f}; the same correction in "
            f"{same} of {int(tri.sum())} (before: leximin often incomplete within the limit, so its "
            "correction can differ)",
        ]
    if args.check > 0:
        lines += check(args.check)
    lines.append(f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the end")
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "triage_paper_size.txt").write_text(text, encoding="utf-8")
    print(text, end="")


if __name__ == "__main__":
    main()
