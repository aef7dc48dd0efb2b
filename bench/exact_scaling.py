"""Exact optimiser at shop scale: paper size up to 300 registers x 5,000 dimensions.

Random process models shaped like the paper's (and like ``../shared/repro``): two thirds
of the registers are WKS, one third tools; every feature is cut by one tool in one WKS
(weights ±1); 70 % of the dimensions measure one feature, 30 % the difference of two;
asymmetric tolerances of 0.02-0.1 mm per side; register limits ±0.1 mm on a 0.001 mm
grid; measurement sets by eqs. 12-13 (w1 = 0.03 mm, w2 = 0.01 mm), rounded to 0.1 µm.

For each size and seed: the solve under the time limit (2 s up to 180 x 2,000, 10 s
above), its wall time per stage, status and which stage stopped, the gap of the error
budget to the LP bound, and the norm of the corrections against the proven least norm
from a solve with a long limit (``--long`` seconds; 0 skips it), and the certified bound
on that ratio the solver states when its least-norm proof stopped.  BLAS single-threaded
(threadpoolctl); a reference workload (one vectorised evaluate of 500 grid solutions of
the 180 x 2,000 problem) is timed before every solve; the CPU time of each solve and the
load average at the start and end are recorded (the machine may be shared).  The summary
also counts the independent blocks of registers (no dimension joins two; more than one
would let the problem decompose).

    python -m bench.exact_scaling                    # sizes up to 300 x 5,000, 5 seeds
    python -m bench.exact_scaling --seeds 2 --long 0
    python -m bench.exact_scaling --objective leximin --seeds 3 --long 0 --max-size 5 \
        --out bench/results/exact_scaling_leximin.txt   # the default objective, with its leximin stage
    python -m bench.exact_scaling --objective leximin --seeds 3 --long 0 --min-size 5 --max-size 5 \
        --limit 20 --out bench/results/exact_scaling_leximin_20s.txt   # 180 x 2,000 with 20 s

``--objective`` is the paper's eqs. 8-9 unless given (the figures of ``exact_scaling.txt``).

Writes ``bench/results/exact_scaling.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
from scipy.sparse import csr_array
from scipy.sparse.csgraph import connected_components
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from bench.problems import shop_problem
from setupfix.core.errors import SetupfixError
from setupfix.optimize import CorrectionProblem, get_optimizer

RESULTS = ROOT / "bench" / "results"
SIZES = [(10, 28), (30, 100), (60, 400), (100, 800), (180, 2000), (300, 5000)]


def register_blocks(problem: CorrectionProblem) -> int:
    """Independent blocks of registers (no dimension joins two): problems that would decompose."""
    touch = csr_array((np.abs(problem.composite) > 0).astype(float))  # (n registers, m dimensions)
    return int(connected_components(touch @ touch.T, directed=False)[0])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--long", type=float, default=60.0, help="limit [s] of the proven least-norm reference")
    parser.add_argument("--max-size", type=int, default=len(SIZES), help="only the first N sizes")
    parser.add_argument("--min-size", type=int, default=1, help="from the N-th size on (1: the first)")
    parser.add_argument(
        "--limit",
        type=float,
        default=None,
        help="time limit [s] of every solve (default: 2 s up to 180 x 2,000, 10 s above)",
    )
    parser.add_argument("--out", type=Path, default=RESULTS / "exact_scaling.txt")
    parser.add_argument("--objective", choices=("paper", "leximin"), default="paper")
    args = parser.parse_args(argv)

    lines: list[str] = []
    wall = time.perf_counter()
    with threadpool_limits(limits=1):
        ref_problem = shop_problem(180, 2000, 0)
        x_ref = ref_problem.snap(np.random.default_rng(0).uniform(-0.1, 0.1, (500, 180)))
        refs = []
        get_optimizer("exact").solve(shop_problem(10, 28, 99))  # warm-up: one-time imports and BLAS scan
        load_start = os.getloadavg()
        header = (
            f"{'size':>11} {'seed':>4} {'limit':>5} {'wall s':>7} {'cpu s':>6} {'lp':>6} {'grid':>6} {'lex':>6} "
            f"{'norm':>6} "
            f"{'status':<11} {'stopped':<26} {'gap µm':>7} {'‖x‖ mm':>8} {'least mm':>8} {'cert ≤':>6}  path"
        )
        lines.append(header)
        summary: list[tuple[int, int, float, list[float], int, list[float], int]] = []
        for n, m in SIZES[args.min_size - 1 : args.max_size]:
            limit = args.limit or (2.0 if n * m <= 180 * 2000 else 10.0)
            times = []
            excess = []
            proved = 0
            blocks = []
            for seed in range(args.seeds):
                problem = shop_problem(n, m, seed)
                blocks.append(register_blocks(problem))
                start = time.perf_counter()
                ref_problem.evaluate(x_ref)  # the reference, interleaved with the solves
                refs.append(time.perf_counter() - start)
                start = time.perf_counter()
                cpu = time.process_time()
                try:
                    result = get_optimizer("exact", time_limit=limit, objective=args.objective).solve(problem)
                except SetupfixError as exc:  # e.g. the LP bound itself not reached within the limit
                    sec = time.perf_counter() - start
                    times.append(sec)
                    lines.append(f"{n:>4} x {m:<5} {seed:>4} {limit:>5.0f} {sec:>7.3f}  refused: {exc}")
                    print(lines[-1], flush=True)
                    continue
                sec = time.perf_counter() - start
                cpu = time.process_time() - cpu
                times.append(sec)
                proved += result.status == "optimal"
                st = dict(result.stages)
                stopped = result.stopped
                stop_text = f"{stopped.stage}: {stopped.reason}" if stopped is not None else "-"
                gap = (float(result.bound or 0.0) - result.margin_after) * 1e3
                least = float("nan")
                if args.long > 0:
                    if result.status == "optimal":
                        least = result.norm
                    else:
                        try:
                            long = get_optimizer("exact", time_limit=args.long, objective=args.objective).solve(problem)
                            least = long.norm if long.status == "optimal" else float("nan")
                        except SetupfixError:
                            least = float("nan")
                if np.isfinite(least) and least > 0:
                    excess.append(result.norm / least)
                cert = result.norm_ratio_max
                cert_text = f"{cert:>6.4f}" if isinstance(cert, float) else f"{'-':>6}"
                lines.append(
                    f"{n:>4} x {m:<5} {seed:>4} {limit:>5.0f} {sec:>7.3f} {cpu:>6.3f} "
                    f"{st.get('lp bound', 0):>6.3f} "
                    f"{st.get('grid optimum', 0):>6.3f} {st.get('leximin', 0):>6.3f} "
                    f"{st.get('least norm', 0):>6.3f} "
                    f"{result.status:<11} {stop_text:<26} {gap:>7.2f} {result.norm:>8.4f} {least:>8.4f} "
                    f"{cert_text}  {result.path}"
                )
                print(lines[-1], flush=True)
            summary.append((n, m, limit, times, proved, excess, max(blocks)))
    ref = float(np.median(refs))
    summary_lines = [
        f"{n:>4} x {m:<5} limit {limit:>4.0f} s: median wall {np.median(times):6.3f} s "
        f"= {np.median(times) / ref:6.2f}x ref, max {np.max(times):6.3f} s; every stage proved "
        f"{proved}/{len(times)}; norm / proven least norm: "
        + (f"max {max(excess):.4f}" if excess else "n/a")
        + f"; independent register blocks, most: {blocks}"
        for n, m, limit, times, proved, excess, blocks in summary
    ]
    head = [
        "Exact optimiser at shop scale (random multi-part fixtures; times in seconds of wall time)",
        f"command : python -m bench.exact_scaling --seeds {args.seeds} --long {args.long:g}"
        + (f" --max-size {args.max_size}" if args.max_size != len(SIZES) else "")
        + (f" --min-size {args.min_size}" if args.min_size != 1 else "")
        + (f" --limit {args.limit:g}" if args.limit else "")
        + (f" --objective {args.objective}" if args.objective != "paper" else ""),
        f"objective: {args.objective} (stages: LP bound, grid optimum"
        + (", leximin levels" if args.objective == "leximin" else "")
        + ", least norm)",
        f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"wall time {time.perf_counter() - wall:.0f} s; BLAS 1 thread (threadpoolctl)",
        f"load    : 1-min load average {load_start[0]:.2f} at the start, {os.getloadavg()[0]:.2f} at the end "
        f"({os.cpu_count()} cores; other processes share them when it exceeds about 1)",
        f"reference: one vectorised evaluate of 500 grid solutions of the 180 x 2,000 problem, timed before "
        f"each solve, median {ref * 1e3:.2f} ms (times / this = ratio); one warm-up solve before the first",
        "columns : cpu = CPU seconds of this process (less sensitive to other processes); lp / grid / lex / norm = "
        "wall seconds of the LP-bound, grid-optimum, leximin and least-norm stages; gap = LP bound − error budget; "
        "least = proven least norm (long limit); cert ≤ = the certified bound on ‖x‖ / least norm when the least-norm "
        "proof "
        "stopped",
        "",
    ]
    text = "\n".join(head + lines + ["", "summary:"] + summary_lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print("\n".join(["", "summary:", *summary_lines]))


if __name__ == "__main__":
    main()
