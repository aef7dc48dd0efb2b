"""Stryczek's comparison (Figs. 12–17) on the guide-pins sample, with the exact grid optimum.

12 seeded trials of CRIPSO, PSO, GA, COA and CS at the paper's budgets on each of
the five bundled cycles; gap = exact f1 − trial f1 in µm.  Speed is given two
ways: against the paper's timings (CRIPSO 0.58 s / 5,000 solutions, PSO 0.96 s /
10,000, GA 0.72 s / 5,000, COA 2.11 s / 30,000; no CS in the paper), and as a
ratio to one vectorised numpy evaluation of the same number of random grid
solutions measured in the same run (machine-independent).

    python -m bench.compare_guide_pins            # writes bench/results/compare_guide_pins.{txt,png}
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from setupfix.inputs.cycles import load_parts
from setupfix.model import load_model
from setupfix.optimize import CorrectionProblem
from setupfix.usecases.compare import DEFAULT_METHODS, compare_problem, plot_comparison

SAMPLE = ROOT / "sample_reports" / "guide_pins"
OUT = ROOT / "bench" / "results"
#: seconds per trial in Stryczek (2014), "Comparison …" section
PAPER_SECONDS = {"cripso": 0.58, "pso": 0.96, "ga": 0.72, "coa": 2.11}
TARGET_UM = {"cripso": 2.0, "pso": 10.0, "ga": 10.0, "coa": 25.0, "cs": 25.0}


def reference_seconds(problem: CorrectionProblem, n: int, repeats: int = 5) -> float:
    """Best of ``repeats`` single vectorised evaluations of n random grid solutions."""
    rng = np.random.default_rng(0)
    x = problem.snap(rng.uniform(problem.lb, problem.ub, size=(n, problem.n_registers)))
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        problem.evaluate(x)
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # BLAS threads change timings 2x on this machine; stated in the output
    OUT.mkdir(parents=True, exist_ok=True)
    model = load_model(SAMPLE / "model.toml")
    lines = [
        "# python -m bench.compare_guide_pins",
        f"# {time.strftime('%Y-%m-%d %H:%M:%S')}, BLAS threads 1 (threadpoolctl)",
        "",
    ]
    pooled: dict[str, dict[str, list[float]]] = {
        m: {"gap": [], "sec": [], "ratio": [], "ev": []} for m in DEFAULT_METHODS
    }
    first = None
    for cycle in range(1, 6):
        part = load_parts(model, SAMPLE / f"cycle_{cycle:02d}.csv")[0]
        problem = CorrectionProblem.from_part(model, part)
        comp = dataclasses.replace(
            compare_problem(problem, trials=12, seed=2014),
            part=part.part,
            report=f"cycle_{cycle:02d}.csv",
            unit=model.unit,
        )
        first = first or comp
        e = comp.exact
        lines.append(
            f"## cycle_{cycle:02d}: f1 before {e.margin_before:+.4f} mm, exact grid optimum "
            f"f1 {e.margin_after:+.4f} mm, f2 {e.norm:.4f} mm, f {e.fitness:+.4f} "
            f"({e.status}, {e.seconds * 1000:.0f} ms, LP bound {e.bound:+.4f})"
        )
        lines.append(
            f"{'method':<7} {'f1 best/med/worst [mm]':>24} {'f2 best/med/worst [mm]':>24} "
            f"{'f best/med/worst':>24} {'sol.':>6} {'ms':>6} {'gap med/worst [µm]':>19}"
        )
        for m in comp.methods:
            s = m.summary(e)
            ref = reference_seconds(problem, int(s["evaluations"]))
            gaps = 1000 * m.gaps(e)
            pooled[m.optimizer]["gap"] += gaps.tolist()
            pooled[m.optimizer]["sec"] += m.seconds.tolist()
            pooled[m.optimizer]["ratio"] += (m.seconds / ref).tolist()
            pooled[m.optimizer]["ev"] += m.evaluations.tolist()
            lines.append(
                f"{m.optimizer:<7} {s['f1_best']:.4f}/{s['f1_median']:.4f}/{s['f1_worst']:.4f}   "
                f"{s['f2_best']:.4f}/{s['f2_median']:.4f}/{s['f2_worst']:.4f}   "
                f"{s['f_best']:.4f}/{s['f_median']:.4f}/{s['f_worst']:.4f} {s['evaluations']:>6.0f} "
                f"{s['seconds'] * 1000:>6.1f} {np.median(gaps):>9.1f}/{gaps.max():<9.1f}"
            )
        lines.append("")
    lines.append("## all five cycles pooled (60 trials per method)")
    lines.append(
        f"{'method':<7} {'gap median':>10} {'gap p90':>8} {'gap worst':>9} {'at optimum':>10} "
        f"{'target':>7} {'sol.':>6} {'ms/trial':>8} {'paper s':>7} {'speed-up':>8} {'× 1 numpy eval':>14}"
    )
    for name, d in pooled.items():
        if not d["gap"]:
            continue
        g = np.array(d["gap"])
        sec = float(np.median(d["sec"]))
        paper = PAPER_SECONDS.get(name)
        speed = f"{paper / sec:>7.0f}×" if paper else f"{'—':>8}"
        lines.append(
            f"{name:<7} {np.median(g):>8.2f}µm {np.percentile(g, 90):>6.1f}µm {g.max():>7.1f}µm "
            f"{np.mean(g < 0.5) * 100:>9.0f}% {TARGET_UM[name]:>5.0f}µm {np.median(d['ev']):>6.0f} "
            f"{sec * 1000:>8.1f} {paper if paper else '—':>7} {speed} {np.median(d['ratio']):>13.1f}×"
        )
    lines += [
        "",
        "gap = exact grid-optimum f1 − trial f1; 'at optimum' = gap < 0.5 µm; speed-up = paper seconds / "
        "our median seconds; last column = our time / one vectorised evaluation of as many solutions.",
    ]
    text = "\n".join(lines) + "\n"
    (OUT / "compare_guide_pins.txt").write_text(text, encoding="utf-8")
    assert first is not None
    plot_comparison(first, OUT / "compare_guide_pins_cycle01.png")
    print(text)


if __name__ == "__main__":
    main()
