"""The point tests and level proofs of the leximin levels: tight rows first, all rows where needed (issue 22).

A point test asks whether a grid point has every row's margin at least its floor
(:func:`setupfix.optimize.exact.leximin.pins.point_above`: can a dimension rise alone, can it be the only
one left at a level, is there a point above the level).  NNLS and the LP answer most; where only a
MILP can tell, the optimiser first solves the MILP of the rows within ``ExactSettings.tight_slack`` steps of the
LP's vertex, and the MILP of all rows only where that one does not decide.

This bench runs the leximin optimiser on the paper-size set of ``bench/leximin_speed.py`` (the five
guide-pins cycles and random sets by eqs. 12-13), records every point test that reaches a MILP, and
then times both MILPs on each (fresh models, HiGHS single-threaded), with the LP of eq. 8 on the
same report as the reference timed in the same run.  Every answer of the tight MILP must agree with
the MILP of all rows where it decides.

It also records every level proof by NNLS (:func:`setupfix.optimize.exact.farkas.farkas_or_point` with the
level's own point): how many of the proofs the rows and box limits within ``NEAR`` steps of the point
hold, and the time of the call with the near columns first against the whole system (best of 5 each).

    python -m bench.point_tests [--sets 100]        # writes bench/results/point_tests.txt
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

import setupfix.optimize.exact.farkas as farkas
import setupfix.optimize.exact.leximin.level as level_mod
import setupfix.optimize.exact.leximin.pins as pins
from bench.leximin_speed import lp_seconds
from bench.problems import guide_pins_problems
from setupfix.optimize import get_optimizer
from setupfix.optimize.exact import ExactSettings
from setupfix.optimize.exact.grid import rounded_rhs
from setupfix.optimize.exact.highs import INF, LinearModel
from setupfix.optimize.exact.session import GridRows

RESULTS = ROOT / "bench" / "results"


def milp(g_rows: np.ndarray, b: np.ndarray, kmin: np.ndarray, kmax: np.ndarray) -> tuple[str, float]:
    """The feasibility MILP G k ≤ b, k integer in the box: its status and wall time (model built and solved)."""
    t = time.perf_counter()
    n = g_rows.shape[1]
    res = LinearModel(
        np.zeros(n), g_rows, np.full(g_rows.shape[0], -INF), b, kmin, kmax, integer=np.ones(n, bool)
    ).solve(60.0)
    return res.status, time.perf_counter() - t


def best_of(call, times: int = 5) -> float:
    best = np.inf
    for _ in range(times):
        t = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - t)
    return best


def level_proofs(proofs: list[tuple[GridRows, np.ndarray, np.ndarray]]) -> list[str]:
    """The level proofs by NNLS: proofs held by the near columns, columns used, and the time of both calls."""
    columns: list[int] = []
    solve = farkas.nnls_solve

    def counted(e: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        columns.append(e.shape[1])
        return solve(e)

    proved = near_proved = 0
    near_cols, all_cols, t_near, t_all = [], [], [], []
    farkas.nnls_solve = counted
    try:
        for rows, b, k in proofs:
            columns.clear()
            y, _ = farkas.farkas_or_point(rows, b, k)
            whole = 2 * rows.n_free + int(np.isfinite(b).sum())
            if y is not None:
                proved += 1
                near_proved += columns[0] < whole and len(columns) == 1
            if columns[0] < whole:
                near_cols.append(columns[0])
            all_cols.append(whole)
    finally:
        farkas.nnls_solve = solve
    for rows, b, k in proofs:
        t_near.append(best_of(functools.partial(farkas.farkas_or_point, rows, b, k)))
        t_all.append(best_of(functools.partial(farkas.farkas_or_point, rows, b)))
    if not proofs:
        return ["level proofs by NNLS: none recorded"]
    return [
        f"level proofs by NNLS at the level's point: {len(proofs)} calls, {proved} proofs; the rows and box limits "
        f"within {farkas.NEAR:g} steps of the point hold {near_proved} of them",
        f"  columns: near median {np.median(near_cols):.0f}, whole system median {np.median(all_cols):.0f}",
        f"  time per call (best of 5): near first {np.sum(t_near) / len(proofs) * 1e6:.0f} us on average, the "
        f"whole system only {np.sum(t_all) / len(proofs) * 1e6:.0f} us (ratio {np.sum(t_near) / np.sum(t_all):.2f})",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=100)
    ap.add_argument("--seed", type=int, default=2014)
    args = ap.parse_args()
    probs = guide_pins_problems(args.sets, args.seed)
    built: list[tuple[np.ndarray, np.ndarray]] = []  # (rows, right-hand sides) of each MILP a point test builds
    cases: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    original, real = pins.LinearModel, level_mod.point_above
    proofs: list[tuple[GridRows, np.ndarray, np.ndarray]] = []  # (rows, b, k) of each level proof by NNLS
    real_farkas = level_mod.farkas_or_point

    def farkas_spy(rows, b, k=None):
        if k is not None:
            proofs.append((rows, b.copy(), k.copy()))
        return real_farkas(rows, b, k)

    class Recorded(original):  # type: ignore[misc, valid-type]
        def __init__(self, c, a, row_lo, row_hi, *rest, **kw):
            super().__init__(c, a, row_lo, row_hi, *rest, **kw)
            built.append((np.asarray(a, dtype=float), np.asarray(row_hi, dtype=float)))

    def spy(session, f, stage_end):
        built.clear()
        out = real(session, f, stage_end)
        if built:  # a MILP was needed: the first one built is the tight one (fewer rows than all), or all rows
            rows = session.rows
            b = rounded_rhs(rows.g, rows.d, rows.zero, f)
            fin = np.isfinite(b)
            a_first, b_first = built[0]
            cases.append((a_first, b_first, rows.g_rows[fin], b[fin], rows.kmin, rows.kmax))
        return out

    refs = []
    with threadpool_limits(limits=1):
        opt = get_optimizer("exact", objective="leximin", time_limit=30.0)
        pins.LinearModel, level_mod.point_above, level_mod.farkas_or_point = Recorded, spy, farkas_spy
        try:
            for _, problem in probs:
                before = len(cases)
                opt.solve(problem)
                if len(cases) > before:
                    refs.append(lp_seconds(problem))
        finally:
            pins.LinearModel, level_mod.point_above, level_mod.farkas_or_point = original, real, real_farkas
        rows_out = []
        for a_tight, b_tight, a_all, b_all, kmin, kmax in cases:
            st_t, sec_t = milp(a_tight, b_tight, kmin, kmax)
            st_a, sec_a = milp(a_all, b_all, kmin, kmax)
            rows_out.append((a_tight.shape[0], a_all.shape[0], st_t, sec_t, st_a, sec_a))
        near = level_proofs(proofs)
    ref = float(np.median(refs)) if refs else float("nan")
    decided = [r for r in rows_out if r[2] == "infeasible" and r[0] < r[1]]
    agree = all(r[4] == "infeasible" for r in decided)
    t_tight = np.array([r[3] for r in rows_out])
    t_all = np.array([r[5] for r in rows_out])
    lines = [
        "Point tests of the leximin levels: the MILP of the tight rows against the MILP of all rows",
        "command : python -m bench.point_tests " + " ".join(sys.argv[1:]),
        f"threads : BLAS limited to 1 (threadpoolctl); HiGHS threads = 1; {os.cpu_count()} CPUs; 1-min load "
        f"{os.getloadavg()[0]:.2f} at the end",
        f"problems: the paper-size set of bench/leximin_speed.py ({len(probs)} reports, seed {args.seed}); "
        f"{len(rows_out)} point tests reached a MILP",
        f"reference: one LP of eq. 8 on the same reports, median {ref * 1e3:.3f} ms",
    ]
    if rows_out:
        lines += [
            f"rows    : tight (within {ExactSettings().tight_slack:g} steps of the LP's vertex) median "
            f"{np.median([r[0] for r in rows_out]):.0f}, all finite median {np.median([r[1] for r in rows_out]):.0f}",
            f"tight MILP: decides (no grid point) {len(decided)} of {len(rows_out)}; median "
            f"{np.median(t_tight) * 1e3:.2f} ms = {np.median(t_tight) / ref:.1f}x LP",
            f"all rows  : median {np.median(t_all) * 1e3:.2f} ms = {np.median(t_all) / ref:.1f}x LP; statuses "
            f"{sorted({r[4] for r in rows_out})}",
            f"agreement: every test the tight MILP decides is infeasible with all rows too: {'yes' if agree else 'NO'}",
        ]
    lines += near
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "point_tests.txt").write_text(text, encoding="utf-8")
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
