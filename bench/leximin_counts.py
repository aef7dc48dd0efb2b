"""Leximin count MILPs and the pair branches that spare them (issue 22: the batch's long tail).

The varied guide-pins reports of ``bench/batch_throughput.py --vary`` (each actual moved by a
seeded step in ±0.005 mm) are corrected once; those whose leximin reaches the counts
(:mod:`setupfix.optimize.exact.leximin.counts`, a discrete conflict that branches cannot decide) are
then corrected again in turn three ways: as before (presolved, HiGHS's default, and no linking
rows), without presolve (:meth:`~setupfix.optimize.exact.highs.LinearModel.skip_presolve`), and without
presolve with the rows w_i,q ≤ w_(i−1),q that link the nested count blocks (what the optimiser does,
``ExactSettings.link_count_blocks``).  Time is process CPU time (the box is shared; wall
time would measure the load), with the in-process reference of the same run (the mean over the five
bundled cycles of ``correct_report``).  The corrections must be identical where the ways are proved.

The reports whose conflict two dimensions must share are decided by branches on pairs
(:func:`setupfix.optimize.exact.leximin.levels.alone_sets`) before the counts: each of them is corrected again with
the pairs switched off (``ExactSettings(max_pair_tests=0)``: the counts, as before), CPU time and answers compared.

    python -m bench.leximin_counts                 # 600 reports, 60 s limit
    python -m bench.leximin_counts --reports 100

Threads: OPENBLAS/MKL/OMP = 1, HiGHS 1 thread.  Writes ``bench/results/leximin_counts.txt``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

import numpy as np

from bench.batch_throughput import reference
from bench.problems import GUIDE, make_reports
from setupfix.model import load_model
from setupfix.optimize.exact import ExactSettings
from setupfix.optimize.exact.highs import LinearModel
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, SolveOptions

RESULTS = ROOT / "bench" / "results"
SKIP = LinearModel.skip_presolve


#: The three ways: (name, presolve on, linking rows).
WAYS = (("before", True, False), ("no presolve", False, False), ("+ links", False, True))


@dataclasses.dataclass(frozen=True)
class Tuned(SolveOptions):
    """The exact optimiser with these settings (the count blocks' links, the pair branches)."""

    settings: ExactSettings = dataclasses.field(default_factory=ExactSettings)

    def params(self) -> dict[str, Any]:
        return {**super().params(), "settings": self.settings}


def tuned(request: CorrectRequest, **settings: Any) -> CorrectRequest:
    """``request`` with the exact optimiser's settings changed."""
    options = Tuned(time_limit=request.solve.time_limit, settings=ExactSettings(**settings))
    return dataclasses.replace(request, solve=options)


def way(request: CorrectRequest, presolve: bool, link: bool) -> CorrectRequest:
    """Count MILPs presolved (HiGHS's default) or not (the optimiser's setting), with or without the links."""
    LinearModel.skip_presolve = (lambda self: None) if presolve else SKIP  # type: ignore[method-assign]
    return tuned(request, link_count_blocks=link)


def solve(request: CorrectRequest, path: Path) -> tuple[float, str, str, np.ndarray]:
    t = time.process_time()
    outcome = correct_report(request, path)
    cpu = time.process_time() - t
    result = outcome.cycles[0].result
    return cpu, result.status, result.path, np.round(result.x, 9)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reports", type=int, default=600)
    ap.add_argument("--limit", type=float, default=60.0)
    args = ap.parse_args()
    request = CorrectRequest(load_model(GUIDE / "model.toml"), solve=SolveOptions(time_limit=args.limit))
    load0 = os.getloadavg()[0]
    ref = reference()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        make_reports(folder, args.reports, vary=True)
        files = sorted(folder.glob("*.csv"))
        way(request, False, True)
        paths = {f: solve(request, f)[2] for f in files}
        counted = [f for f in files if "the rest by counts" in paths[f]]
        paired = []
        for f in (f for f in files if "branch: dimensions" in paths[f]):
            with_pairs = solve(request, f)
            paired.append((f.name, with_pairs, solve(tuned(request, max_pair_tests=0), f)))
        rows = []
        for f in counted:
            runs = {}
            for name, presolve, link in WAYS:
                runs[name] = solve(way(request, presolve, link), f)
            rows.append((f.name, runs))
        way(request, False, True)
    lines = [
        "Leximin count MILPs: HiGHS presolve, the nested blocks' linking rows and the pair branches, process CPU time",
        f"command : python -m bench.leximin_counts --reports {args.reports} --limit {args.limit:g}",
        "threads : OPENBLAS/MKL/OMP = 1, HiGHS threads = 1",
        f"load    : 1-min load average {load0:.2f} at the start, {os.getloadavg()[0]:.2f} at the end",
        f"reference: in-process correct_report of the five bundled cycles, mean {ref * 1e3:.2f} ms (wall)",
        f"reports : {args.reports} varied guide-pins reports; {len(counted)} reach the counts",
        "ways    : before = presolve on, no links; no presolve; + links = no presolve and the links (the optimiser)",
        "",
        f"{'report':<12}" + "".join(f"{name + ': CPU s':>20}" for name, _, _ in WAYS) + "  same answer (proved ways)",
    ]
    totals = {name: 0.0 for name, _, _ in WAYS}
    for name, runs in rows:
        cells = "".join(f"{runs[w][0]:>12.2f} {runs[w][1][:7]:>7}" for w, _, _ in WAYS)
        proved = [runs[w][3] for w, _, _ in WAYS if runs[w][1] == "optimal"]
        same = all(np.array_equal(proved[0], x) for x in proved[1:]) if proved else None
        lines.append(
            f"{name:<12}{cells}  {'yes' if same else 'NO' if same is False else '-'}"
            f" ({len(proved)} of {len(WAYS)} proved)"
        )
        for w, _, _ in WAYS:
            totals[w] += runs[w][0]
    lines += ["", "total CPU s: " + ", ".join(f"{w} {t:.2f}" for w, t in totals.items())]
    lines += [
        "",
        f"pair branches: {len(paired)} of {args.reports} reports meet a conflict two dimensions must share; "
        "each with the pairs (the optimiser) and without them (the counts, as before)",
        f"{'report':<12}{'pairs: CPU s':>20}{'counts: CPU s':>20}  same answer (proved ways)",
    ]
    for name, (c_p, st_p, _, x_p), (c_c, st_c, _, x_c) in paired:
        same = (
            "yes"
            if st_p == st_c == "optimal" and np.array_equal(x_p, x_c)
            else ("NO" if st_p == st_c == "optimal" else "-")
        )
        lines.append(f"{name:<12}{c_p:>12.2f} {st_p[:7]:>7}{c_c:>12.2f} {st_c[:7]:>7}  {same}")
    if paired:
        pairs_cpu, counts_cpu = sum(r[1][0] for r in paired), sum(r[2][0] for r in paired)
        lines.append(f"total CPU s: pairs {pairs_cpu:.2f}, counts {counts_cpu:.2f}")
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "leximin_counts.txt").write_text(text)
    print(text, end="")


if __name__ == "__main__":
    main()
