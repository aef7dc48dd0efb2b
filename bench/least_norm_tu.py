"""Least norm on network rows: one chord LP against the listing and MILP proofs it replaces.

Problems: random multi-part fixtures as ``bench/exact_scaling.py`` but every dimension measures one
feature, cut by one tool in one WKS (weights ±1, no differences of two features): the margin rows
are a network matrix after flipping the tool columns, totally unimodular, and the rounded rows b are
integral, so the least Σ c k² over the grid is the vertex of one LP over the chords of k²
(:func:`setupfix.optimize.exact.least_norm.shop.network_rows`).

For each size and seed the exact solve runs three times in the same process: the network LP
first (``network_lp`` on, no listing before it: ``ellipsoid_max_registers`` = 0), without it
(``network_lp`` off: the listing, box MILPs and chord MILPs as before), and as shipped (the short
listing of up to 120 registers, then the network LP before any MILP).  Reported: the least-norm
stage's time of each, whether the corrections are equal (norms must be; the correction too unless
a tie was too large to list) and the ratio of each stage time to one LP solve timed in the same
run, interleaved with the work (the max-min LP of the problem: min −t, G k + t ≤ g, box; HiGHS,
single thread).  BLAS single-threaded.

    python -m bench.least_norm_tu               # sizes up to 300 x 5,000, 3 seeds
    python -m bench.least_norm_tu --seeds 1 --max-size 3

Writes ``bench/results/least_norm_tu.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.optimize.exact import ExactSettings
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.lp_bound import margin_rows

RESULTS = ROOT / "bench" / "results"
SIZES = [(10, 28), (30, 100), (60, 400), (100, 800), (180, 2000), (300, 5000)]


def network_problem(n: int, m: int, seed: int) -> CorrectionProblem:
    """n registers (two thirds WKS), m dimensions, each one feature: one WKS and one tool, same sign."""
    rng = np.random.default_rng(seed)
    n_wks = max(1, 2 * n // 3)
    comp = np.zeros((n, m))
    sign = rng.choice([-1.0, 1.0], m)
    comp[rng.integers(0, n_wks, m), np.arange(m)] = sign
    comp[n_wks + rng.integers(0, n - n_wks, m), np.arange(m)] = sign
    lower = -np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    upper = np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    dev = np.round(0.03 * (1 - 2 * rng.random(n)) @ comp + 0.01 * (1 - 2 * rng.random(m)), 4)
    return CorrectionProblem(
        composite=comp,
        deviation=dev,
        lower=lower,
        upper=upper,
        lb=np.full(n, -0.1),
        ub=np.full(n, 0.1),
        resolution=0.001,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


def one_lp(problem: CorrectionProblem) -> float:
    """Wall time of one max-min LP solve of the problem (the reference)."""
    g_rows, g = margin_rows(problem)
    lo, hi = problem.kmin.astype(float), problem.kmax.astype(float)
    r, n = g_rows.shape
    model = LinearModel(
        np.r_[np.zeros(n), -1.0],
        np.hstack([g_rows, np.ones((r, 1))]),
        np.full(r, -INF),
        g,
        np.r_[lo, -INF],
        np.r_[hi, INF],
    )
    start = time.perf_counter()
    res = model.solve(60.0)
    assert res.status == "optimal"
    return time.perf_counter() - start


def solve(
    problem: CorrectionProblem, network: bool, limit: float, listing: bool = True
) -> tuple[float, float, str, np.ndarray, str]:
    settings = (
        ExactSettings(network_lp=network) if listing else ExactSettings(network_lp=network, ellipsoid_max_registers=0)
    )
    result = get_optimizer("exact", time_limit=limit, settings=settings).solve(problem)
    stages = dict(result.stages)
    path = result.path
    return float(stages.get("least norm", np.nan)), result.norm, result.status, result.x, path


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--max-size", type=int, default=len(SIZES))
    parser.add_argument("--limit", type=float, default=30.0, help="time limit [s] of each solve")
    parser.add_argument("--out", type=Path, default=RESULTS / "least_norm_tu.txt")
    args = parser.parse_args(argv)
    lines = [
        f"$ python -m bench.least_norm_tu {' '.join(argv if argv is not None else sys.argv[1:])}".rstrip(),
        f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
        f"{platform.python_version()}; load at start {os.getloadavg()[0]:.2f}",
        f"{'size':>11} {'seed':>4} {'1 LP ms':>8} {'LP ms':>8} {'LP/1LP':>6} {'old ms':>8} {'old/1LP':>7} "
        f"{'now ms':>8} {'now/1LP':>7} {'same':>5}  old path (least norm)",
    ]
    print("\n".join(lines), flush=True)
    summary = []
    with threadpool_limits(limits=1):
        solve(network_problem(10, 28, 99), True, args.limit)  # warm-up
        for n, m in SIZES[: args.max_size]:
            ratios: dict[str, list[float]] = {"lp": [], "old": [], "now": []}
            for seed in range(args.seeds):
                problem = network_problem(n, m, seed)
                lp = [one_lp(problem)]
                t_lp, norm_lp, st_lp, x_lp, path_lp = solve(problem, True, args.limit, listing=False)
                lp.append(one_lp(problem))
                t_old, norm_old, st_old, x_old, path_old = solve(problem, False, args.limit)
                lp.append(one_lp(problem))
                t_now, norm_now, st_now, x_now, path_now = solve(problem, True, args.limit)
                lp.append(one_lp(problem))
                ref = float(np.median(lp))
                untied = "the tie is not broken" not in path_lp + path_old + path_now
                same = (
                    st_lp == st_old == st_now == "optimal"
                    and abs(norm_lp - norm_old) <= 1e-12
                    and abs(norm_now - norm_old) <= 1e-12
                    and (not untied or (np.array_equal(x_lp, x_old) and np.array_equal(x_now, x_old)))
                )
                old_steps = "; ".join(p for p in path_old.split("; ") if p.startswith("least norm"))
                lines.append(
                    f"{n:>4} x {m:<5} {seed:>4} {ref * 1e3:>8.2f} {t_lp * 1e3:>8.2f} {t_lp / ref:>6.1f} "
                    f"{t_old * 1e3:>8.2f} {t_old / ref:>7.1f} {t_now * 1e3:>8.2f} {t_now / ref:>7.1f} "
                    f"{same!s:>5}  {old_steps[:100]}"
                )
                print(lines[-1], flush=True)
                if "one LP over the chords" not in path_lp:
                    lines.append(f"    network LP not taken: {path_lp}")
                if not untied:
                    lines.append("    a tie too large to list (the corrections may differ; the norms may not)")
                if not same:
                    lines.append(
                        f"    DIFFERENT: norms {norm_lp!r} / {norm_old!r} / {norm_now!r}, "
                        f"status {st_lp} / {st_old} / {st_now}"
                    )
                ratios["lp"].append(t_lp / ref)
                ratios["old"].append(t_old / ref)
                ratios["now"].append(t_now / ref)
            summary.append(
                f"{n:>4} x {m:<5} least-norm stage / one LP, median: network LP first "
                f"{np.median(ratios['lp']):6.1f}x, without it {np.median(ratios['old']):6.1f}x, "
                f"as shipped {np.median(ratios['now']):6.1f}x"
            )
    lines += ["", "summary (medians over the seeds):", *summary]
    print("\n".join(lines[-len(summary) - 2 :]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
