"""Truncation sweep (issue 10): every sample cut at 40 byte points and 40 line ends, each prefix refused or a subset.

Run: ``python -m bench.parse_truncation > bench/results/parse_truncation.txt``
(``--shared DIR`` for the samples of ../shared/cmm-samples; default ../shared beside the project).

A prefix "changed" when it yields a row that is not a row of the whole file: a wrong
number.  The goal is zero.  Single-threaded; no timings.
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from parsers.truncation import check_prefixes, cut_points, line_cut_points
from setupfix.core.errors import SetupfixError

SKIP_SUFFIXES = {".md", ".py", ".toml", ".png"}


def samples(shared: Path) -> list[Path]:
    found = [p for p in sorted((ROOT / "sample_reports").rglob("*")) if p.is_file()]
    found += [p for p in sorted((shared / "cmm-samples").rglob("*")) if p.is_file()]
    return [p for p in found if p.suffix.lower() not in SKIP_SUFFIXES and not p.name.startswith(("SOURCES", "."))]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    ap.add_argument("--cuts", type=int, default=40)
    args = ap.parse_args()
    totals: collections.Counter[str] = collections.Counter()
    files = 0
    for path in samples(args.shared):
        data = path.read_bytes()
        try:
            cuts = cut_points(len(data), args.cuts) + line_cut_points(data, args.cuts)
            outcomes = check_prefixes(str(path), data, sorted(set(cuts)))
        except SetupfixError:
            continue  # not a readable report as a whole (plans, configuration files): nothing to compare
        files += 1
        counts = collections.Counter(o.verdict for o in outcomes)
        totals.update(counts)
        rel = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.relative_to(args.shared)
        print(
            f"{rel}: {len(data)} bytes, {counts['refused']} refused, {counts['subset']} subset, "
            f"{counts['changed']} changed"
        )
        for o in outcomes:
            if o.verdict == "changed":
                print(f"    cut {o.cut}: {o.detail}")
    print(
        f"TOTAL {files} readable samples x ({args.cuts} byte + {args.cuts} line-end) cuts: "
        f"{totals['refused']} refused, "
        f"{totals['subset']} subset, {totals['changed']} changed"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
