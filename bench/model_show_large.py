"""``setupfix model show`` on generated models of 1,000 to 10,000 dimensions (issue 21, item 11).

Each size runs in a fresh interpreter (``python -m setupfix model show MODEL``, output
discarded); wall time, CPU time (children's user + system) and the child's peak
resident memory are given, and the time as a ratio to the 1,000-dimension model
timed in the same run: a linear command gives ratios near the size ratio (10 for
10,000), a quadratic one near its square (100).  Before the fix the 10,000-dimension
model took 87 s and 3.5 GB (dense 10,000 × 10,000 grids printed cell by cell, and a
10,000 × 10,000 SVD factor for the null space).

    python -m bench.model_show_large               # sizes 1000 2000 5000 10000

Writes ``bench/results/model_show_large.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"


def model_text(n: int, n_wks: int = 10, n_tools: int = 40) -> str:
    """A model of ``n`` features and ``n`` dimensions, each dimension the difference of two features."""
    out = [
        "[process]",
        f'name = "generated, {n} dimensions"',
        'axis = "Z"',
        'unit = "mm"',
        "resolution = 0.001",
        "limit = 0.1",
    ]
    out += [f'[wks.W{i}]\nregister = "G54.1 P{i}"' for i in range(1, n_wks + 1)]
    out += [f'[tools.T{i}]\nregister = "H{i}"' for i in range(1, n_tools + 1)]
    out += [
        f"[features.F{j}]\nwks = {{ W{j % n_wks + 1} = 1 }}\ntools = {{ T{j % n_tools + 1} = 1 }}"
        for j in range(1, n + 1)
    ]
    out += [
        f'[dimensions.D{j}]\nname = "dim {j}"\nfeatures = {{ F{j} = 1, F{j % n + 1} = -1 }}\n'
        f"nominal = 10.0\nlower = -0.1\nupper = 0.1"
        for j in range(1, n + 1)
    ]
    return "\n".join(out) + "\n"


def timed(path: Path) -> tuple[float, float, int]:
    """Wall [s], CPU [s] and peak RSS [kB] of one ``model show`` (peak: the largest child so far)."""
    before = os.times()
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "setupfix", "model", "show", str(path)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    wall = time.perf_counter() - start
    after = os.times()
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return wall, cpu, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 5000, 10000])
    parser.add_argument("--out", type=Path, default=RESULTS / "model_show_large.txt")
    args = parser.parse_args(argv)
    sizes = sorted(set(args.sizes))  # ascending: the children's peak RSS is then that of the latest
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            path = Path(tmp) / f"model_{n}.toml"
            path.write_text(model_text(n), encoding="utf-8")
            rows.append((n, *timed(path)))
    ref_n, _, ref_cpu, _ = rows[0]
    lines = [
        f"setupfix model show on generated models (reference: {ref_n} dimensions, same run)",
        f"command : python -m bench.model_show_large {' '.join(sys.argv[1:])}".rstrip(),
        f"machine : {platform.machine()}, Python {platform.python_version()}",
        "",
        f"{'dimensions':>10} {'wall [s]':>9} {'CPU [s]':>8} {'peak RSS [MB]':>14} {'x size':>7} {'x CPU':>7}",
    ]
    for n, wall, cpu, rss in rows:
        lines.append(f"{n:>10} {wall:>9.2f} {cpu:>8.2f} {rss / 1024:>14.0f} {n / ref_n:>7.1f} {cpu / ref_cpu:>7.2f}")
    lines += ["", "linear: x CPU ≈ x size; quadratic: ≈ its square. Before the fix: 10,000 dimensions 87 s, 3.5 GB."]
    text = "\n".join(lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
