"""Triage with no harm inside the optimum against the old triage + re-solve (issue 22), on hard problems.

Hard problems: the shop-shaped fixtures of ``bench.problems.shop_problem`` (two thirds WKS, one third
tools, 30 % difference dimensions, ±0.1 mm limits on a 0.001 mm grid) with a larger random part
of each deviation (``--noise``, default ±0.045 mm on top of eq. 12's setup error), so that about a
tenth of the dimensions are measured out of tolerance and no correction brings all of them in.

Each problem goes through ``setupfix.correction.recommend.recommend`` (neutral policy) twice: in this tree and
in ``--old`` (a checkout of the tree before issue 22, run in a subprocess), both under the same
time limit.  Stated per problem: dimensions measured in tolerance, kept in tolerance after the
recommended correction (new, old), whether the answer moves a dimension measured in tolerance out
(must be 0), the status, the wall time, and its ratio to one LP (max t, every margin ≥ t, the
register bounds; HiGHS through ``setupfix.optimize.exact.highs``) solved in the same process just
before.  BLAS single-threaded; the load average is recorded (the machine may be shared).

    python -m bench.triage_no_harm                          # 30 x 100, 60 x 400, 180 x 2,000; 5 seeds
    python -m bench.triage_no_harm --seeds 2 --old /work/main

Writes ``bench/results/triage_no_harm.txt`` (with the command).
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

from bench.problems import shop_problem

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
SIZES = [(30, 100), (60, 400), (180, 2000)]


def one_lp_seconds(problem) -> float:
    """Wall time of one LP: max t s.t. every margin ≥ t, register bounds (HiGHS, as the solver uses it)."""
    from setupfix.optimize.exact.highs import INF, LinearModel
    from setupfix.optimize.exact.lp_bound import margin_rows

    g_rows, g = margin_rows(problem)
    free = problem.free
    a = np.hstack([g_rows, np.ones((g.size, 1))])
    start = time.perf_counter()
    model = LinearModel(
        np.r_[np.zeros(int(free.sum())), -1.0],
        a,
        np.full(g.size, -INF),
        g,
        np.r_[problem.kmin[free], -INF],
        np.r_[problem.kmax[free], INF],
    )
    model.solve(60.0)
    return time.perf_counter() - start


def run(sizes: list[tuple[int, int]], seeds: int, noise: float, limit: float) -> list[dict[str, object]]:
    """Every problem through recommend in the tree this process imports; one record per problem."""
    from threadpoolctl import threadpool_limits

    from setupfix.correction.pose import pose_policy
    from setupfix.correction.recommend import recommend
    from setupfix.correction.safety import Policy, harmed_mask
    from setupfix.optimize import get_optimizer

    out = []
    with threadpool_limits(limits=1):
        get_optimizer("exact").solve(shop_problem(10, 28, 99, noise))  # warm-up: imports, BLAS scan
        for n, m in sizes:
            for seed in range(seeds):
                p = shop_problem(n, m, seed, noise)
                lp = one_lp_seconds(p)
                opt = get_optimizer("exact", time_limit=limit)
                start = time.perf_counter()
                rec = recommend(pose_policy(p, Policy.neutral(p)), opt.solve)
                sec = time.perf_counter() - start
                margins = p.margins(rec.x)
                inside = (p.deviation >= p.lower) & (p.deviation <= p.upper)
                triage = rec.result.triage
                out.append(
                    {
                        "n": n,
                        "m": m,
                        "seed": seed,
                        "measured_in": int(inside.sum()),
                        "kept": int((margins >= -1e-12).sum()),
                        "given_up": len(rec.given_up),
                        "harmed": int(harmed_mask(p.deviation, p.predicted(rec.x), p.lower, p.upper).sum()),
                        "verdict": rec.verdict,
                        "status": rec.result.status,
                        "seconds": sec,
                        "lp": lp,
                        "levels": triage.leximin_levels if triage is not None else 0,
                    }
                )
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--noise", type=float, default=0.045, help="random part of each deviation [mm]")
    parser.add_argument("--limit", type=float, default=2.0, help="time limit of each solve [s]")
    parser.add_argument("--max-size", type=int, default=len(SIZES))
    parser.add_argument("--old", type=Path, default=Path("/work/main"), help="tree before issue 22 ('' skips)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=RESULTS / "triage_no_harm.txt")
    args = parser.parse_args(argv)
    sizes = SIZES[: args.max_size]
    if args.worker:  # a subprocess in another tree: records as JSON on stdout
        print(json.dumps(run(sizes, args.seeds, args.noise, args.limit)))
        return
    load_start = os.getloadavg()
    new = run(sizes, args.seeds, args.noise, args.limit)
    old: list[dict[str, object]] = []
    if str(args.old):
        cmd = [
            sys.executable,
            str(Path(__file__).resolve()),
            "--worker",
            "--seeds",
            str(args.seeds),
            "--noise",
            str(args.noise),
            "--limit",
            str(args.limit),
            "--max-size",
            str(args.max_size),
        ]
        # this file as a script, importing setupfix from --old and bench from this tree
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(args.old), str(ROOT)])}
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, cwd=str(args.old))
        old = json.loads(done.stdout)
    load_end = os.getloadavg()
    lines = [
        f"{'size':>11} {'seed':>4} {'in before':>9} {'kept new':>8} {'kept old':>8} {'harm':>4} "
        f"{'status new':<11} {'status old':<11} {'levels':>6} {'s new':>7} {'s old':>7} {'LP ms':>6} "
        f"{'new/LP':>7}"
    ]
    for i, r in enumerate(new):
        o = old[i] if i < len(old) else {}
        lines.append(
            f"{r['n']:>4} x {r['m']:<5} {r['seed']:>4} {r['measured_in']:>9} {r['kept']:>8} "
            f"{o.get('kept', '-'):>8} {r['harmed']:>4} {r['status']:<11} {o.get('status', '-')!s:<11} "
            f"{r['levels']:>6} {r['seconds']:>7.3f} {o.get('seconds', float('nan')):>7.3f} "
            f"{1e3 * float(r['lp']):>6.1f} {float(r['seconds']) / float(r['lp']):>7.0f}"
        )
    lines.append("")
    for n, m in sizes:
        rs = [r for r in new if r["n"] == n]
        os_ = [o for o in old if o["n"] == n]
        kept_new = [int(r["kept"]) for r in rs]
        kept_old = [int(o["kept"]) for o in os_]
        fewer_old = sum(int(o["kept"]) < int(r["kept"]) for r, o in zip(rs, os_, strict=False))
        lines.append(
            f"{n} x {m}: kept new median {np.median(kept_new):.0f} (range {min(kept_new)}–{max(kept_new)})"
            + (
                f", old median {np.median(kept_old):.0f} (range {min(kept_old)}–{max(kept_old)}), "
                f"old keeps fewer in {fewer_old} of {len(rs)}"
                if kept_old
                else ""
            )
            + f"; new median {np.median([float(r['seconds']) for r in rs]):.3f} s = "
            f"{np.median([float(r['seconds']) / float(r['lp']) for r in rs]):.0f}× one LP; "
            f"proved {sum(r['status'] == 'optimal' for r in rs)} of {len(rs)}; "
            f"harmful answers {sum(int(r['harmed']) > 0 for r in rs)}"
        )
    lines.append("")
    lines.append(
        f"noise ±{args.noise} mm, time limit {args.limit} s per solve; 'kept' = dimensions predicted in "
        "tolerance after the recommended correction; 'harm' = measured in tolerance, predicted out"
    )
    lines.append(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"load average {load_start[0]:.2f} → {load_end[0]:.2f}"
    )
    lines.append("command: python -m bench.triage_no_harm " + " ".join(argv or sys.argv[1:]))
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
