"""Where a leximin solve at shop scale spends its time: a discrete conflict's alone tests, the count MILPs.

One 180 x 2,000 problem of ``bench/exact_scaling.py`` (seed 1: a discrete conflict at 18 steps that the
counts decide), solved with the default objective and a 20 s limit, twice:

* as the optimiser does it: one Farkas certificate from the rows near the level's point rules out the
  dimensions it does not lean on before any alone test (:func:`setupfix.optimize.exact.leximin.levels.alone_sets`);
* with that certificate switched off beyond small problems (how the previous stop's code ran): every
  active dimension at the level is tested alone, each test an LP or MILP.

For each: the conflict's alone tests (how many, seconds; with the certificate, its NNLS on the near rows
timed against NNLS on the whole system), each count MILP (its binaries against the
active dimensions, the time it was given and took), ``meeting_rounding``'s calls and seconds, the
levels reached, the wall time and the correction's norm.  BLAS and HiGHS single-threaded.

    python -m bench.leximin_shop_trace          # writes bench/results/leximin_shop_trace.txt
"""

from __future__ import annotations

import argparse
import functools
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", OMP_NUM_THREADS="1")

import numpy as np
from threadpoolctl import threadpool_limits

import setupfix.optimize.exact.leximin.counts as countmod
import setupfix.optimize.exact.leximin.levels as lexmod
import setupfix.optimize.exact.leximin.pins as pins
from bench.problems import shop_problem
from setupfix.optimize import get_optimizer

RESULTS = ROOT / "bench" / "results"


def _traced(lines: list[str], whole_only: bool) -> Callable[[], None]:
    """Wrap the functions to trace; returns the undo."""
    saved: list[tuple[Any, str, Any]] = []

    def patch(owner: Any, name: str, new: Any) -> None:
        saved.append((owner, name, getattr(owner, name)))
        setattr(owner, name, new)

    alone = lexmod.alone_sets

    @functools.wraps(alone)
    def traced_alone(search, v, k, t, together):  # type: ignore[no-untyped-def]
        calls, began = search.calls, time.perf_counter()
        out = alone(search, v, k, t, together)
        lines.append(
            f"  alone tests ({'singles' if together == 1 else 'pairs'}) at {t:.4g} steps: "
            f"{search.calls - calls} tests, {time.perf_counter() - began:.3f} s, "
            f"{'stopped' if out is None else len(out)} found"
        )
        return out

    patch(lexmod, "alone_sets", traced_alone)
    if whole_only:
        excluded = lexmod.excluded_alone

        def no_near(rows, floors, row_dim, n_dims, t, eps, together=1, near=None):  # type: ignore[no-untyped-def]
            if near is not None:  # the previous code sought no certificate beyond small problems
                return np.zeros((n_dims,) * together, bool)
            return excluded(rows, floors, row_dim, n_dims, t, eps, together, near)

        patch(lexmod, "excluded_alone", no_near)
    model = countmod.count_model

    def traced_model(rows, blocks, extra, question, objective, top, t_lo):  # type: ignore[no-untyped-def]
        lp, layout = model(rows, blocks, extra, question, objective, top, t_lo)
        solve = lp.solve

        def timed(limit, *start):  # type: ignore[no-untyped-def]
            began = time.perf_counter()
            res = solve(limit, *start)
            lines.append(
                f"  {objective:<8} MILP, {len(blocks)} block(s) before it: binaries "
                f"{int(layout.dims[-1].size)} of {rows.n_active} active dimensions in its own block, "
                f"{lp.n_rows} rows; given {limit:.2f} s, took {time.perf_counter() - began:.2f} s "
                f"({res.status})"
            )
            return res

        lp.solve = timed
        return lp, layout

    patch(countmod, "count_model", traced_model)
    farkas = pins.farkas_or_point
    timed_once: list[bool] = []

    def near_and_whole(rows, b, k=None, whole=True):  # type: ignore[no-untyped-def]
        if whole or k is None or timed_once:
            return farkas(rows, b, k, whole)
        timed_once.append(True)  # the first near-only certificate: timed against NNLS on the whole system
        began = time.perf_counter()
        out = farkas(rows, b, k, False)
        near_s = time.perf_counter() - began
        began = time.perf_counter()
        whole_out = farkas(rows, b)
        lines.append(
            f"  the conflict's certificate: NNLS on the rows near the point {near_s:.3f} s "
            f"({'a proof' if out[0] is not None else 'none'}), on the whole system "
            f"{time.perf_counter() - began:.3f} s ({'a proof' if whole_out[0] is not None else 'none'})"
        )
        return out

    patch(pins, "farkas_or_point", near_and_whole)
    rounding = pins.meeting_rounding
    spent = [0, 0.0]

    def timed_rounding(*a, **kw):  # type: ignore[no-untyped-def]
        began = time.perf_counter()
        out = rounding(*a, **kw)
        spent[0] += 1
        spent[1] += time.perf_counter() - began
        return out

    patch(pins, "meeting_rounding", timed_rounding)

    def undo() -> None:
        lines.append(f"  meeting_rounding: {spent[0]} calls, {spent[1]:.3f} s")
        for owner, name, old in reversed(saved):
            setattr(owner, name, old)

    return undo


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--limit", type=float, default=20.0)
    parser.add_argument("--out", type=Path, default=RESULTS / "leximin_shop_trace.txt")
    args = parser.parse_args(argv)
    lines = [
        "Leximin at shop scale, traced: a discrete conflict's alone tests and the count MILPs",
        f"command : python -m bench.leximin_shop_trace --seed {args.seed} --limit {args.limit:g}",
        f"machine : {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"{os.cpu_count()} CPUs; BLAS 1 thread (threadpoolctl), HiGHS 1 thread",
        f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the start",
        f"problem : bench/problems.py shop_problem(180, 2000, seed {args.seed}), objective leximin, "
        f"time limit {args.limit:g} s",
    ]
    with threadpool_limits(limits=1):
        get_optimizer("exact").solve(shop_problem(10, 28, 99))  # warm-up: imports
        problem = shop_problem(180, 2000, args.seed)
        for title, whole_only in (
            ("the optimiser (near-row certificate beyond small problems)", False),
            ("no certificate beyond small problems (the previous stop's way)", True),
        ):
            lines += ["", f"{title}:"]
            undo = _traced(lines, whole_only)
            began = time.perf_counter()
            try:
                result = get_optimizer("exact", objective="leximin", time_limit=args.limit).solve(problem)
            finally:
                undo()
            path = result.path.split("; ")
            levels = [p for p in path if "dimension(s) at" in p or "counts:" in p]
            lines.append(
                f"  wall {time.perf_counter() - began:.2f} s, status {result.status}, stages "
                + ", ".join(f"{k} {v:.2f} s" for k, v in result.stages.items())
                + f"; correction norm {result.norm:.4f} mm"
            )
            lines.append(f"  levels proved ({len(levels)}): " + "; ".join(p.replace("leximin ", "") for p in levels))
            print("\n".join(lines), flush=True)
    lines.append(f"load    : 1-min load average {os.getloadavg()[0]:.2f} at the end")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
