"""Metaheuristic time per trial: this tree against an earlier commit, interleaved in one run.

Separates what a code change costs from what the machine's state costs: both trees solve
the same problem (guide-pins cycle 01) with the same seeds, alternating A B A B, each in its
own process with OpenBLAS/MKL/OMP threads = 1.  The earlier commit is checked out into a
temporary git worktree and removed afterwards.

    python -m bench.optimizer_speed_vs_commit --base e62cc1d   # writes bench/results/optimizer_speed_vs_commit.txt
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "optimizer_speed_vs_commit.txt"
METHODS = ("cripso", "pso", "ga", "coa", "cs")

# Runs inside each tree, from its root (the current directory: its setupfix is the one imported):
# medians of `seeds` trials per method, as JSON on stdout.
CHILD = r"""
import json, sys, time
from setupfix.model import load_model
try:
    from setupfix.inputs.cycles import load_parts
except ImportError:  # a base commit older than pipeline/cycles.py (ab2835b)
    from setupfix.usecases.correct import load_parts
from setupfix.optimize import CorrectionProblem, get_optimizer
root, seeds, methods = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
model = load_model(root + "/sample_reports/guide_pins/model.toml")
part = load_parts(model, root + "/sample_reports/guide_pins/cycle_01.csv")[0]
problem = CorrectionProblem.from_part(model, part)
out = {}
for name in methods:
    times = []
    for seed in range(seeds):
        opt = get_optimizer(name, seed=seed)
        t = time.perf_counter(); result = opt.solve(problem); times.append(time.perf_counter() - t)
    out[name] = {"seconds": times, "f1": result.margin_after}
print(json.dumps(out))
"""


def run_tree(root: Path, seeds: int) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(root), str(seeds), ",".join(METHODS)],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="e62cc1d", help="earlier commit to compare with")
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--rounds", type=int, default=2, help="A B pairs")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "-q", "--detach", str(old), args.base], cwd=ROOT, check=True)
        try:
            runs: dict[str, list[dict]] = {"base": [], "this": []}
            for _ in range(args.rounds):
                runs["base"].append(run_tree(old, args.seeds))
                runs["this"].append(run_tree(ROOT, args.seeds))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(old)], cwd=ROOT, check=False)
    head = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    lines = [
        f"$ python -m bench.optimizer_speed_vs_commit --base {args.base} --seeds {args.seeds} --rounds {args.rounds}",
        f"guide-pins cycle 01; {args.seeds} seeds per method and round; {args.rounds} interleaved rounds; "
        "BLAS threads 1; median ms per trial over all rounds",
        f"{'method':<8}{'base ' + args.base:>16}{'this ' + head:>16}{'this / base':>13}   f1 base / this [mm]",
    ]
    for name in METHODS:
        b = statistics.median(t for r in runs["base"] for t in r[name]["seconds"]) * 1000
        t = statistics.median(t for r in runs["this"] for t in r[name]["seconds"]) * 1000
        lines.append(
            f"{name:<8}{b:>16.1f}{t:>16.1f}{t / b:>13.2f}   "
            f"{runs['base'][-1][name]['f1']:.4f} / {runs['this'][-1][name]['f1']:.4f}"
        )
    text = "\n".join(lines) + "\n"
    OUT.write_text(text, encoding="utf-8")
    print(text, end="")


if __name__ == "__main__":
    main()
