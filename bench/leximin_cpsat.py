"""The leximin's count band at shop scale on an independent engine: Google OR-Tools' CP-SAT.

Whether a stronger off-the-shelf solver would put a proved leximin at 180 x 2,000 within reach.
CP-SAT solves the same chain of questions as :mod:`setupfix.optimize.exact.leximin.counts`, on the
integer model itself (units of 0.1 µm: deviations are rounded to it, tolerances are 5 µm
multiples, a register step is 1 µm, so every margin is an integer):

* **value** t₁: max t with every dimension's margin ≥ t (the paper's δ on the grid);
* **count** at t_i: max Σ b_q, b_q ⇒ margin_q ≥ t_i + 1 (the blocks found so far held);
* **value** t_(i+1): max t with Σ b_q ≥ N_(i+1), b_q ⇒ margin_q ≥ t; the block (t_(i+1), N_(i+1)) joins.

Each question is one CP-SAT solve with all the machine's workers and a cap of ``--cap`` seconds.
The optimiser's own answer to the same problem (the default objective, ``--limit`` seconds) is
printed beside it: its wall time and its point's smallest margins, which must agree with every value
and count CP-SAT proves as far as the optimiser's levels reached.

Needs ``pip install ortools`` (not a dependency of setupfix; used here only as a reference).

    python -m bench.leximin_cpsat          # writes bench/results/leximin_cpsat.txt
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

import numpy as np
from ortools.sat.python import cp_model
from threadpoolctl import threadpool_limits

from bench.problems import shop_problem
from setupfix.optimize import CorrectionProblem, get_optimizer

RESULTS = ROOT / "bench" / "results"
UNIT = 1e-4  # mm: 0.1 µm


class Chain:
    """The count chain of one problem on CP-SAT (integer margins in units of 0.1 µm)."""

    def __init__(self, problem: CorrectionProblem, cap: float) -> None:
        self.a = np.rint(problem.composite.T).astype(int)  # (m, n), entries in {-2..2}
        step = round(problem.resolution / UNIT)
        self.hi = np.rint((problem.upper - problem.deviation) / UNIT).astype(int)  # margin = hi - step·a k
        self.lo = np.rint((problem.deviation - problem.lower) / UNIT).astype(int)  # margin = lo + step·a k
        self.step, self.kmin, self.kmax, self.cap = step, problem.kmin, problem.kmax, cap
        self.blocks: list[tuple[int, int]] = []
        self.t1: int | None = None  # every margin ≥ t1 once the first value is known

    def _model(self) -> tuple[cp_model.CpModel, list[cp_model.LinearExpr]]:
        mdl = cp_model.CpModel()
        k = [mdl.NewIntVar(int(a), int(b), f"k{j}") for j, (a, b) in enumerate(zip(self.kmin, self.kmax, strict=True))]
        moved = [
            sum(int(self.step * self.a[i, j]) * k[j] for j in np.flatnonzero(self.a[i])) for i in range(self.a.shape[0])
        ]
        return mdl, moved

    def _above(self, mdl: cp_model.CpModel, moved: list[cp_model.LinearExpr], level: object) -> list[cp_model.IntVar]:
        """One binary per dimension: b ⇒ its margin ≥ level (an int or a model variable)."""
        out = []
        for i, e in enumerate(moved):
            b = mdl.NewBoolVar(f"b{i}")
            mdl.Add(self.hi[i] - e >= level).OnlyEnforceIf(b)  # type: ignore[operator]
            mdl.Add(self.lo[i] + e >= level).OnlyEnforceIf(b)  # type: ignore[operator]
            out.append(b)
        return out

    def _held(self, mdl: cp_model.CpModel, moved: list[cp_model.LinearExpr]) -> None:
        """Every margin ≥ t1 and the blocks found so far."""
        if self.t1 is not None:
            for i, e in enumerate(moved):
                mdl.Add(self.hi[i] - e >= self.t1)
                mdl.Add(self.lo[i] + e >= self.t1)
        for t, count in self.blocks:
            mdl.Add(sum(self._above(mdl, moved, t)) >= count)

    def _solve(self, mdl: cp_model.CpModel) -> tuple[str, float, float]:
        s = cp_model.CpSolver()
        s.parameters.max_time_in_seconds = self.cap
        s.parameters.num_workers = os.cpu_count() or 1
        began = time.perf_counter()
        status = s.Solve(mdl)
        return s.StatusName(status), s.ObjectiveValue(), time.perf_counter() - began

    def value(self, count: int | None) -> tuple[str, float, float]:
        mdl, moved = self._model()
        t = mdl.NewIntVar(-(10**6), 10**6, "t")
        if count is None:
            for i, e in enumerate(moved):
                mdl.Add(self.hi[i] - e >= t)
                mdl.Add(self.lo[i] + e >= t)
        else:
            mdl.Add(sum(self._above(mdl, moved, t)) >= count)
        self._held(mdl, moved)
        mdl.Maximize(t)
        return self._solve(mdl)

    def count(self, t: int) -> tuple[str, float, float]:
        mdl, moved = self._model()
        self._held(mdl, moved)
        mdl.Maximize(sum(self._above(mdl, moved, t + 1)))
        return self._solve(mdl)


def full_vector(chain: Chain, m: int) -> tuple[list[tuple[int, int]], bool, int, float]:
    """The leximin vector by the chain: [(value in units, how many at it)], whether it is whole (False: a
    question was not proved within the cap; the values before it are), questions, seconds."""
    status, t, total = chain.value(None)
    chain.t1, asked, out, prev = int(t), 1, [], m
    while status == "OPTIMAL":
        status, above, secs = chain.count(int(t))
        total, asked = total + secs, asked + 1
        if status != "OPTIMAL":
            break
        out.append((int(t), prev - int(above)))
        prev = int(above)
        if prev == 0:
            return out, True, asked, total
        status, t, secs = chain.value(prev)
        total, asked = total + secs, asked + 1
        chain.blocks.append((int(t), prev))
    return out, False, asked, total


def full(args: argparse.Namespace, lines: list[str]) -> None:
    """``--full``: the optimiser's proved leximin vector against the whole chain on CP-SAT."""
    lines.append(
        f"the whole leximin vector: the optimiser ({args.limit:g} s limit, proved answers only) against "
        f"the CP-SAT chain to its end (each question capped at {args.cap:g} s)"
    )
    lines.append(
        f"{'size':>10} {'seed':>4} {'optimiser':>10} {'wall s':>7} {'values':>6} {'questions':>9} "
        f"{'CP-SAT s':>8}  same vector"
    )
    for size in args.full.split(","):
        n, m = (int(v) for v in size.split("x"))
        for seed in range(args.seeds):
            problem = shop_problem(n, m, seed)
            with threadpool_limits(1):
                began = time.perf_counter()
                res = get_optimizer("exact", time_limit=args.limit).solve(problem)
                wall = time.perf_counter() - began
            units = np.rint(problem.margins(np.asarray(res.x)) / UNIT).astype(int)
            mine = [(int(v), int(c)) for v, c in zip(*np.unique(units, return_counts=True), strict=True)]
            theirs, whole, asked, secs = full_vector(Chain(problem, args.cap), m)
            diff = next(
                (i for i, (a, b) in enumerate(zip(mine, theirs, strict=False)) if a != b),
                None if len(mine) == len(theirs) or not whole else min(len(mine), len(theirs)),
            )
            if diff is not None:
                verdict = f"NO: value {diff}: {mine[diff : diff + 1]} against {theirs[diff : diff + 1]} (units, count)"
            else:
                verdict = "yes" if whole else f"the first {len(theirs)} values (CP-SAT stopped at the next question)"
            if res.status != "optimal":
                verdict += f"; optimiser {res.status}"
            lines.append(
                f"{n:>4} x {m:<4} {seed:>4} {res.status:>10} {wall:>7.2f} {len(mine):>6} {asked:>9} "
                f"{secs:>8.1f}  {verdict}"
            )
            print(lines[-1], flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="180x2000")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--questions", type=int, default=4, help="CP-SAT solves in the chain")
    ap.add_argument("--cap", type=float, default=150.0, help="seconds per CP-SAT solve")
    ap.add_argument("--limit", type=float, default=20.0, help="the optimiser's time limit [s]")
    ap.add_argument("--full", default="", help="sizes (e.g. 10x28,30x100): whole vectors compared instead")
    ap.add_argument("--seeds", type=int, default=5, help="seeds per size with --full")
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    args.out = args.out or str(RESULTS / ("leximin_cpsat_full.txt" if args.full else "leximin_cpsat.txt"))
    lines = [
        "The leximin on an independent engine (CP-SAT) against the optimiser",
        f"command : python -m bench.{Path(__file__).stem} " + " ".join(sys.argv[1:]),
        f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}, "
        f"ortools {__import__('ortools').__version__}; {os.cpu_count()} CPUs",
        f"threads : CP-SAT {os.cpu_count()} workers; the optimiser BLAS 1 thread (threadpoolctl), HiGHS 1 thread",
        f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the start",
    ]
    if args.full:
        full(args, lines)
        _write(args, lines)
        return
    n, m = (int(v) for v in args.size.split("x"))
    problem = shop_problem(n, m, args.seed)
    lines += [
        f"problem : bench/problems.py shop_problem({n}, {m}, seed {args.seed}); margins in 0.1 µm "
        f"(the optimiser's steps are 1 µm = 10 units); each CP-SAT solve capped at {args.cap:g} s",
        "",
    ]
    with threadpool_limits(1):
        began = time.perf_counter()
        res = get_optimizer("exact", time_limit=args.limit).solve(problem)
        wall = time.perf_counter() - began
    units = np.sort(np.rint(problem.margins(np.asarray(res.x)) / UNIT).astype(int))
    values, counts = np.unique(units, return_counts=True)
    smallest = ", ".join(f"{v / 10:g} x{c}" for v, c in zip(values[:12], counts[:12], strict=True))
    lines.append(
        f"the optimiser ({args.limit:g} s limit): wall {wall:.2f} s, status {res.status}; its point's "
        f"smallest margins [steps] x how many: {smallest}; {values.size} distinct margins in all (a proved "
        "leximin proves each)"
    )
    lines.append("")
    lines.append("CP-SAT, question by question:")
    chain, total = Chain(problem, args.cap), 0.0
    status, t, secs = chain.value(None)
    total += secs
    chain.t1 = int(t)
    lines.append(f"  value  t1 = {t:g} units = {t / 10:g} steps ({status}) {secs:.2f} s")
    print(lines[-1], flush=True)
    asked = 1
    while status == "OPTIMAL" and asked < args.questions:
        status, above, secs = chain.count(int(t))
        total, asked = total + secs, asked + 1
        lines.append(
            f"  count  at {t / 10:g} steps: {int(above)} of {m} above, {m - int(above)} at or below it "
            f"({status}) {secs:.2f} s; the optimiser's point: {int(np.sum(units > t))} above"
        )
        print(lines[-1], flush=True)
        if status != "OPTIMAL" or asked >= args.questions:
            break
        status, t, secs = chain.value(int(above))
        total, asked = total + secs, asked + 1
        chain.blocks.append((int(t), int(above)))
        lines.append(f"  value  of the {int(above)} above: {t / 10:g} steps ({status}) {secs:.2f} s")
        print(lines[-1], flush=True)
    lines.append(f"  CP-SAT total {total:.1f} s")
    _write(args, lines)


def _write(args: argparse.Namespace, lines: list[str]) -> None:
    lines.append(f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the end")
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
