"""`setupfix batch` of this tree against an earlier commit, interleaved in one run.

On a busy machine absolute times move by 2× from one minute to the next; running the
two trees alternately on the same reports gives a ratio that does not.  The commit is
exported with ``git archive`` into a temporary folder and both trees run
``python -m setupfix batch`` from their own root (the current directory comes first
on the import path), with 1 and 2 workers, ``--rounds`` times each; the median wall time of each
is reported with the ratio this/commit, and the offsets files of the two trees are
compared byte for byte.  OpenBLAS/MKL/OMP threads are pinned to 1.

    python -m bench.batch_vs_commit [--commit 990b710] [--reports 300] [--rounds 3] [--vary]
                                    [--time-limit S] [--out FILE]
    # writes bench/results/batch_vs_commit.txt (or FILE); rows differing between the trees are counted
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import subprocess
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

from bench.batch_throughput import run
from bench.problems import make_reports

OUT = ROOT / "bench" / "results" / "batch_vs_commit.txt"


def export(commit: str, target: Path) -> str:
    """Write the tree of ``commit`` into ``target``; its short hash."""
    data = subprocess.run(["git", "archive", commit], cwd=ROOT, capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(target, filter="data")
    return subprocess.run(
        ["git", "rev-parse", "--short", commit], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--commit", default="990b710", help="the earlier tree (default: main before issue 15's batch work)")
    ap.add_argument("--reports", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--vary", action="store_true", help="every report with its own deviations")
    ap.add_argument("--time-limit", type=float, default=None, help="each solve's limit in both trees")
    ap.add_argument("--out", type=Path, default=OUT, help=f"the result file (default: {OUT.relative_to(ROOT)})")
    args = ap.parse_args()
    args.out = args.out.resolve()
    extra = () if args.time_limit is None else ("--time-limit", f"{args.time_limit:g}")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        base.mkdir()
        short = export(args.commit, base)
        folder = Path(tmp) / "reports"
        folder.mkdir()
        make_reports(folder, args.reports, args.vary)
        times: dict[tuple[str, int], list[float]] = {}
        outputs: dict[tuple[str, int], bytes] = {}
        for _ in range(args.rounds):
            for workers in (1, 2):
                for name, tree in ((short, base), ("this", ROOT)):
                    out = Path(tmp) / f"{name}_{workers}.csv"
                    times.setdefault((name, workers), []).append(run(folder, out, workers, tree, extra))
                    outputs[(name, workers)] = out.read_bytes()
    kind = "varied copies (own deviations)" if args.vary else "copies repeating five problems"
    lines = [
        f"setupfix batch on {args.reports} guide-pins reports ({kind}), this tree against {short}, "
        f"interleaved, median of {args.rounds}; OPENBLAS/MKL/OMP threads = 1"
    ]
    for workers in (1, 2):
        a, b = statistics.median(times[(short, workers)]), statistics.median(times[("this", workers)])
        lines.append(f"workers {workers}: {short} {a:.2f} s, this {b:.2f} s; this/{short} = {b / a:.2f}")
    same = len(set(outputs.values())) == 1
    lines.append(f"offsets files of both trees and both worker counts: {'identical' if same else 'DIFFER'}")
    for workers in (1, 2):
        a, b = outputs[(short, workers)].decode().splitlines(), outputs[("this", workers)].decode().splitlines()
        differing = sum(x != y for x, y in zip(a, b, strict=False)) + abs(len(a) - len(b))
        lines.append(f"workers {workers}: {differing} of {len(a) - 1} offset rows differ between the trees")
    command = (
        f"$ python -m bench.batch_vs_commit --commit {args.commit} --reports {args.reports} "
        f"--rounds {args.rounds}"
        + (" --vary" if args.vary else "")
        + ("" if args.time_limit is None else f" --time-limit {args.time_limit:g}")
        + ("" if args.out == OUT else f" --out {args.out.relative_to(ROOT)}")
    )
    args.out.write_text(command + "\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
