"""The exact optimiser's work limits: what they cost, how much room they leave, how fast the guard acts.

Issue 37 #4 moved the solver's stages from wall-clock shares to work units (HiGHS iterations and
nodes, the heavier numpy steps; ``setupfix/optimize/exact/work.py``); the wall-clock
``--time-limit`` only guards against a hang.  Three measurements, each time given as a ratio to a
reference timed in the same process (one vectorised ``problem.evaluate`` of 5,000 random grid
points, as ``bench/exact_per_report.py``), never as an absolute:

1. **cost** — every bundled sample's solve (guide pins cycles 1-5, two stations X/Y/Z cycles 1-3,
   controllers), this tree against ``--base`` (the commit before the change), alternating A B A B,
   each tree in its own process with one BLAS thread: median time per solve / reference, and the
   after/before ratio;
2. **room** — the work each sample's solve spends against ``ExactSettings.work_limit`` (this tree;
   work is deterministic: the same on every machine);
3. **guard** — what the tests used to assert in seconds (tests/optimize/test_highs.py,
   test_exact_robust.py, tests/parsers/test_safety.py): how long after its guard a hard MIP is
   interrupted, how long a 10^10-step grid solve takes, how long the billion-laughs QIF takes to
   be refused — each / reference.

    python -m bench.work_limits --base e00ff3d      # writes bench/results/work_limits.txt
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "work_limits.txt"
ENV = {"OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}

#: Runs inside each tree (its root is the current directory and on PYTHONPATH): per sample, the
#: median solve time / the reference, status, work (None where the tree does not count it); JSON.
CHILD = r"""
import json, sys, time
import numpy as np
from setupfix.model import load_model
from setupfix.inputs.cycles import load_parts
from setupfix.correction.pose import pose_problem
from setupfix.optimize import get_optimizer
root, repeats = sys.argv[1], int(sys.argv[2])
cases = [("guide_pins", f"cycle_0{k}.csv") for k in range(1, 6)]
cases += [("two_station_xyz", f"cycle_0{k}.csv") for k in range(1, 4)] + [("controllers", "report.csv")]
rng = np.random.default_rng(0)
out = {}
for folder, report in cases:
    model = load_model(f"{root}/sample_reports/{folder}/model.toml")
    part = load_parts(model, f"{root}/sample_reports/{folder}/{report}")[0]
    problem = pose_problem(model, part).guarded
    points = rng.integers(-5, 6, (5000, problem.n_registers)) * problem.resolution
    times, refs, statuses, work = [], [], set(), None
    optimizer = get_optimizer("exact")
    optimizer.solve(problem)  # imports and memo warm
    for _ in range(repeats):
        problem.evaluate(points)  # untimed: the first after a solve pays for the allocator (exact_per_report)
        t = time.perf_counter(); problem.evaluate(points); refs.append(time.perf_counter() - t)
        t = time.perf_counter(); r = optimizer.solve(problem); times.append(time.perf_counter() - t)
        statuses.add(r.status)
        work = getattr(r, "work", None)
    out[f"{folder}/{report}"] = {
        "ratio": float(np.median(times) / np.median(refs)),
        "status": sorted(statuses),
        "work": work,
    }
print(json.dumps(out))
"""

#: This tree only: the wall-clock measurements the tests no longer assert.
GUARD = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, ".")
from setupfix.optimize.exact import work
from setupfix.optimize.exact.highs import LinearModel
root = sys.argv[1]
rng = np.random.default_rng(0)
ref_points = rng.integers(-5, 6, (5000, 10)) * 0.001
def reference():
    from setupfix.model import load_model
    from setupfix.inputs.cycles import load_parts
    from setupfix.optimize import CorrectionProblem
    model = load_model(f"{root}/sample_reports/guide_pins/model.toml")
    problem = CorrectionProblem.from_part(model, load_parts(model, f"{root}/sample_reports/guide_pins/cycle_01.csv")[0])
    times = []
    for _ in range(9):
        t = time.perf_counter(); problem.evaluate(ref_points); times.append(time.perf_counter() - t)
    return float(np.median(times)), problem
ref, coarse = reference()
out = {"reference_s": ref}
# 1. a hard MIP (market split) with a far work allowance: the guard's interrupt, 0.3 s after the start
r = np.random.default_rng(0)
a = r.integers(0, 100, (5, 40)).astype(float); b = np.floor(a.sum(axis=1) / 2)
over = []
for _ in range(3):
    model = LinearModel(np.zeros(40), a, b, b, np.zeros(40), np.ones(40), integer=np.ones(40, bool))
    token = work.CURRENT.set(work.Meter(guard=work.wall() + 0.3))
    t = time.perf_counter(); res = model.solve(1e12); wall = time.perf_counter() - t
    work.CURRENT.reset(token)
    assert res.status == "time_limit"
    over.append(wall - 0.3)
out["guard_overshoot_per_ref"] = float(np.median(over) / ref)
# 2. a 10^10-step grid (resolution 1e-11 mm): the whole solve
import dataclasses
from setupfix.optimize import get_optimizer
fine = dataclasses.replace(coarse, resolution=1e-11)
t = time.perf_counter(); res = get_optimizer("exact", objective="paper").solve(fine); wall = time.perf_counter() - t
out["fine_grid_per_ref"] = wall / ref
out["fine_grid_status"] = res.status
# 3. the billion-laughs QIF refused
import ast, tempfile, pathlib, parsers
from setupfix.core.errors import ParseError
tree = ast.parse(pathlib.Path("tests/parsers/test_safety.py").read_text(encoding="utf-8"))
BILLION_LAUGHS = next(
    n.value.value for n in tree.body
    if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "BILLION_LAUGHS"
)
with tempfile.TemporaryDirectory() as d:
    p = pathlib.Path(d) / "bomb.qif"; p.write_text(BILLION_LAUGHS, encoding="utf-8")
    t = time.perf_counter()
    try:
        parsers.read_report(p).table
        refused = False
    except ParseError:
        refused = True
    out["billion_laughs_per_ref"] = (time.perf_counter() - t) / ref
    out["billion_laughs_refused"] = refused
print(json.dumps(out))
"""


def run_child(tree: Path, code: str, *args: str) -> dict[str, object]:
    env = {**os.environ, **ENV, "PYTHONPATH": str(tree)}
    done = subprocess.run(
        [sys.executable, "-c", code, str(tree), *args], cwd=tree, env=env, capture_output=True, text=True
    )
    if done.returncode:
        sys.exit(f"{tree}: the child failed:\n{done.stderr}")
    data: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return data


def base_tree(base: str, where: Path) -> Path:
    """The base commit's files, unpacked (no worktree, no checkout: the repository is left as it is)."""
    archive = subprocess.run(["git", "archive", base], cwd=ROOT, capture_output=True, check=True).stdout
    tree = where / "base"
    tree.mkdir()
    with tempfile.TemporaryFile() as f:
        f.write(archive)
        f.seek(0)
        with tarfile.open(fileobj=f) as tar:
            tar.extractall(tree, filter="data")
    return tree


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="e00ff3d", help="the commit before the work limits")
    ap.add_argument("--repeats", type=int, default=5, help="solves per sample and process")
    ap.add_argument("--rounds", type=int, default=2, help="A B pairs")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = base_tree(args.base, Path(tmp))
        runs: dict[str, list[dict[str, object]]] = {"after": [], "before": []}
        for _ in range(args.rounds):
            runs["after"].append(run_child(ROOT, CHILD, str(args.repeats)))
            runs["before"].append(run_child(base, CHILD, str(args.repeats)))
    guard = run_child(ROOT, GUARD)
    from setupfix.optimize.exact import ExactSettings

    limit = ExactSettings().work_limit
    lines = [
        f"$ python -m bench.work_limits --base {args.base} --repeats {args.repeats} --rounds {args.rounds}",
        f"python {sys.version.split()[0]}, {os.cpu_count()} cores; BLAS threads 1; A B alternated {args.rounds}x",
        "",
        "1. cost: median solve time per sample / reference (5,000 grid points evaluated), each tree's",
        "   median over its rounds; after = this tree (work limits), before = --base (wall-clock shares)",
        f"{'sample':34s} {'before':>9s} {'after':>9s} {'after/before':>12s}  status before → after",
    ]
    ratios = []
    for key in runs["after"][0]:
        b = statistics.median(float(r[key]["ratio"]) for r in runs["before"])  # type: ignore[index]
        a = statistics.median(float(r[key]["ratio"]) for r in runs["after"])  # type: ignore[index]
        ratios.append(a / b)
        sb = sorted({s for r in runs["before"] for s in r[key]["status"]})  # type: ignore[index]
        sa = sorted({s for r in runs["after"] for s in r[key]["status"]})  # type: ignore[index]
        lines.append(f"{key:34s} {b:9.1f} {a:9.1f} {a / b:12.2f}  {','.join(sb)} → {','.join(sa)}")
    lines += [f"{'median of the samples':34s} {'':9s} {'':9s} {statistics.median(ratios):12.2f}", ""]
    lines += [
        f"2. room: work spent per sample against ExactSettings().work_limit = {limit:,.0f} units",
        f"{'sample':34s} {'work':>10s} {'limit/work':>10s}",
    ]
    for key, value in runs["after"][0].items():
        w = float(value["work"])  # type: ignore[index, arg-type]
        lines.append(f"{key:34s} {w:10.0f} {limit / max(w, 1.0):10.0f}")
    lines += [
        "",
        "3. the guard and the refusals the tests no longer time (each / reference "
        f"{float(guard['reference_s']) * 1e3:.3f} ms)",  # type: ignore[arg-type]
        f"hard MIP, guard at 0.3 s: interrupted this long after it     {guard['guard_overshoot_per_ref']:10.1f}",
        f"10^10-step grid, whole solve ({guard['fine_grid_status']})              {guard['fine_grid_per_ref']:10.1f}",
        f"billion-laughs QIF refused ({guard['billion_laughs_refused']})                 "
        f"{guard['billion_laughs_per_ref']:10.1f}",
    ]
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
