"""Start-up time of the command line: ``setupfix --help`` and ``--version`` against ``python -c pass``.

Each command runs ``--repeat`` times in a fresh interpreter (``python -m setupfix …``
from the project root); the median wall and CPU times (children's user + system) are
given, and each as a ratio to ``python -c pass`` timed interleaved in the same run.

    python -m bench.cli_startup            # 15 repeats

Writes ``bench/results/cli_startup.txt`` (with the command).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"
COMMANDS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "setupfix --help": [sys.executable, "-m", "setupfix", "--help"],
    "setupfix --version": [sys.executable, "-m", "setupfix", "--version"],
}


def timed(cmd: list[str]) -> tuple[float, float]:
    before = os.times()
    start = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    wall = time.perf_counter() - start
    after = os.times()
    return wall, (after.children_user - before.children_user) + (after.children_system - before.children_system)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--out", type=Path, default=RESULTS / "cli_startup.txt")
    args = parser.parse_args(argv)
    walls: dict[str, list[float]] = {k: [] for k in COMMANDS}
    cpus: dict[str, list[float]] = {k: [] for k in COMMANDS}
    for _ in range(args.repeat):
        for name, cmd in COMMANDS.items():
            w, c = timed(cmd)
            walls[name].append(w)
            cpus[name].append(c)
    ref_w, ref_c = np.median(walls["python -c pass"]), np.median(cpus["python -c pass"])
    lines = [
        "CLI start-up: fresh interpreter per call, median of the repeats",
        f"command : python -m bench.cli_startup --repeat {args.repeat}",
        f"machine : {platform.machine()}, Python {platform.python_version()}",
        "",
        f"{'command':<22}{'wall [s]':>10}{'x pass':>8}{'CPU [s]':>10}{'x pass':>8}",
    ]
    for name in COMMANDS:
        w, c = np.median(walls[name]), np.median(cpus[name])
        lines.append(f"{name:<22}{w:>10.3f}{w / ref_w:>8.2f}{c:>10.3f}{c / ref_c:>8.2f}")
    help_cpu = np.median(cpus["setupfix --help"])
    lines += [
        "",
        f"target  : --help and --version <= 0.2 s (CPU {help_cpu:.3f} s: "
        f"{'met' if help_cpu <= 0.2 else 'not met'}; wall depends on the machine's load)",
    ]
    text = "\n".join(lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(text, end="")


if __name__ == "__main__":
    main()
