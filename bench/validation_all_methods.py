"""Stryczek's statistical validation (Fig. 18) for every method, with the exact optimum.

100 measurement sets of the guide-pins model drawn by eqs. 12–13 (w1 = 0.03 mm,
w2 = 0.02 mm), 10 seeded trials per set and method at the paper's budgets; the
exact grid optimum of each set is the yardstick.  Writes the table to
bench/results/validation_all_methods.txt and Fig. 18 with gaps to
bench/results/validation_all_methods.png.

    python -m bench.validation_all_methods [--sets 100] [--trials 10]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from setupfix.correction.synthetic import simulate_deviations
from setupfix.model import PartMeasurement, load_model
from setupfix.optimize import CorrectionProblem
from setupfix.outputs.plots import validation_figure
from setupfix.outputs.writers import write_figure
from setupfix.usecases.compare import DEFAULT_METHODS, compare_problem

OUT = ROOT / "bench" / "results"
TARGET_UM = {"cripso": 2.0, "pso": 10.0, "ga": 10.0, "coa": 25.0, "cs": 25.0}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", type=int, default=100)
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--seed", type=int, default=18)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # BLAS threads change timings 2x on this machine; stated in the output
    OUT.mkdir(parents=True, exist_ok=True)
    model = load_model(ROOT / "sample_reports" / "guide_pins" / "model.toml")
    devs, _ = simulate_deviations(model, args.sets, w1=0.03, w2=0.02, seed=args.seed)
    n_dims = len(model.dimensions)
    initial, exact_f1, exact_f, exact_status = [], [], [], []
    f1: dict[str, list[np.ndarray]] = {m: [] for m in DEFAULT_METHODS}
    fit: dict[str, list[np.ndarray]] = {m: [] for m in DEFAULT_METHODS}
    sec: dict[str, list[float]] = {m: [] for m in DEFAULT_METHODS}
    start = time.perf_counter()
    for s, dev in enumerate(devs):
        part = PartMeasurement(
            part=f"set {s + 1}", report="simulated", timestamp=None, deviation=dev, sources=("",) * n_dims
        )
        problem = CorrectionProblem.from_part(model, part)
        comp = compare_problem(problem, trials=args.trials, seed=args.seed * 1000 + s)
        initial.append(comp.exact.margin_before)
        exact_f1.append(comp.exact.margin_after)
        exact_f.append(comp.exact.fitness)
        exact_status.append(comp.exact.status)
        for m in comp.methods:
            f1[m.optimizer].append(m.f1)
            fit[m.optimizer].append(m.f)
            sec[m.optimizer] += m.seconds.tolist()
    wall = time.perf_counter() - start
    ini, ex, exf = np.array(initial), np.array(exact_f1), np.array(exact_f)
    lines = [
        f"# python -m bench.validation_all_methods --sets {args.sets} --trials {args.trials} --seed {args.seed}",
        f"# {time.strftime('%Y-%m-%d %H:%M:%S')}, {wall:.0f} s wall, BLAS threads 1 (threadpoolctl)",
        "",
        f"{args.sets} sets by eqs. 12–13 (w1 = 0.03, w2 = 0.02 mm); f1 before correction from {ini.min():+.4f} "
        f"to {ini.max():+.4f} mm (median {np.median(ini):+.4f}); exact grid optimum from {ex.min():+.4f} to "
        f"{ex.max():+.4f} mm (median {np.median(ex):+.4f}); exact status: "
        + ", ".join(f"{k} {exact_status.count(k)}" for k in sorted(set(exact_status))),
        f"bonus b = exact − before: median {np.median(ex - ini) * 1000:.1f} µm, "
        f"range {np.min(ex - ini) * 1000:.1f} to {np.max(ex - ini) * 1000:.1f} µm",
        "",
        f"{'method':<7} {'trials':>6} {'gap median':>10} {'p90':>7} {'p99':>7} {'worst':>7} {'at opt.':>7} "
        f"{'sets with median gap > target':>30} {'f gap median':>12} {'ms/trial':>8}",
    ]
    per_method = {}
    for name in DEFAULT_METHODS:
        if not f1[name]:
            continue
        a = np.vstack(f1[name])  # (sets, trials)
        per_method[name] = a
        gap = 1000 * (ex[:, None] - a)
        fgap = 1000 * (exf[:, None] - np.vstack(fit[name]))
        over = int(np.sum(np.median(gap, axis=1) > TARGET_UM[name]))
        lines.append(
            f"{name:<7} {gap.size:>6} {np.median(gap):>8.2f}µm {np.percentile(gap, 90):>5.1f}µm "
            f"{np.percentile(gap, 99):>5.1f}µm {gap.max():>5.1f}µm {np.mean(gap < 0.5) * 100:>6.0f}% "
            f"{over:>20} (target {TARGET_UM[name]:.0f}µm) {np.median(fgap):>12.2f} "
            f"{np.median(sec[name]) * 1000:>8.1f}"
        )
    lines += [
        "",
        "gap = exact grid-optimum f1 − trial f1 [µm]; at opt. = gap < 0.5 µm; f gap = exact f − trial f "
        "[10⁻³, the exact f maximises f1 first, then least ‖x‖].",
    ]
    text = "\n".join(lines) + "\n"
    (OUT / "validation_all_methods.txt").write_text(text, encoding="utf-8")
    fig = validation_figure(
        ini,
        ex,
        per_method,
        unit=model.unit,
        title=f"Fig. 18 redone: {args.sets} sets × {args.trials} trials, sorted by f1 before correction",
    )
    write_figure(fig, OUT / "validation_all_methods.png")
    print(text)


if __name__ == "__main__":
    main()
