"""Replay of one machine-year: 8,760 hourly guide-pin parts (28 dimensions, 10 registers), issue 40.

The history is made by the replay engine itself run as a closed loop (a setup error, a known drift per
dimension and noise; dead band 10 %, gain 0.5, mean of 3), stored as one report per part in a history
store with its corrections log: an SQLite file, and the PostgreSQL server given by ``--db`` (or
``$SETUPFIX_TEST_PG``) when there is one.  Timed on each, best of ``--rounds``:

* read: the series reader (:func:`setupfix.inputs.series.load_series`) over the store;
* replay: :func:`setupfix.usecases.replay.replay_history` of one rule set (read included; the
  walk-forward error is not computed above 400 parts);
* grid (with ``--grid``): the same with the default grid (36 rule sets).

Times are ratios to a reference timed in the same run (the best of five SVDs of a 1000 × 300 matrix,
as the other benches), with the seconds beside them.

    python -m bench.replay_year [--parts 8760] [--db postgresql://…]   # → bench/results/replay_year.txt
    python -m bench.replay_year --engine-only      # the engine alone, no store → replay_year_engine.txt
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]

from bench.diagnosis import svd_seconds
from setupfix.correction.relation import relation_matrices
from setupfix.correction.replay import replay_rules
from setupfix.inputs.series import load_series
from setupfix.model import load_model
from setupfix.model.safety import Rules
from setupfix.store import open_store
from setupfix.usecases.parse import parse_reports
from setupfix.usecases.replay import ReplayRequest, replay_history

OUT = ROOT / "bench" / "results" / "replay_year.txt"
MODEL = ROOT / "sample_reports" / "guide_pins" / "model.toml"
USED = Rules(dead_band_share=0.1, gain=0.5, mean_of=3)
START = pd.Timestamp("2026-01-01T00:00:00")


def history(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(parts as measured, changes in effect) of a closed loop under :data:`USED` over ``n`` parts."""
    model = load_model(MODEL)
    c = relation_matrices(model).composite
    rng = np.random.default_rng(40)
    base = (
        rng.uniform(-0.03, 0.03, c.shape[0]) @ c
        + np.arange(n)[:, None] * np.linspace(-2e-5, 3e-5, c.shape[1])[None, :]
        + rng.normal(0, 0.004, (n, c.shape[1]))
    )
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    trace = replay_rules(base, np.zeros((n, c.shape[0])), c, lower, upper, model.resolution, USED)
    return trace.deviation, trace.applied


def fill(location: str, parts: np.ndarray, applied: np.ndarray) -> None:
    model = load_model(MODEL)
    template = parse_reports([ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv"]).table
    names = [d.name for d in model.dimensions]
    index = [names.index(str(c)) for c in template["characteristic"]]
    registers = [r.register for r in model.registers]
    with open_store(location, machine="year") as store, store.transaction():
        for t, row in enumerate(parts):
            table = template.copy()
            table["deviation"] = row[index]
            table["actual"] = table["nominal"] + table["deviation"]
            table["part"] = table["report"] = f"h{t:05d}"
            table["timestamp"] = (START + pd.Timedelta(hours=t)).isoformat()
            store.add_report(f"year {t}".encode(), f"h{t:05d}.csv", "canonical", table)
        steps = np.diff(applied, axis=0)
        rows = [
            ((START + pd.Timedelta(hours=t, minutes=30)).isoformat(), registers[j], float(steps[t, j]), "correction")
            for t in np.flatnonzero(np.any(steps != 0, axis=1))
            for j in np.flatnonzero(steps[t])
        ]
        store.add_corrections(pd.DataFrame(rows, columns=["timestamp", "register", "delta", "event"]))


def best(fn, rounds: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", type=int, default=8760)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--db", default=os.environ.get("SETUPFIX_TEST_PG", ""), help="an empty PostgreSQL database")
    ap.add_argument("--grid", action="store_true", help="also time the default grid (36 rule sets)")
    ap.add_argument("--engine-only", action="store_true", help="time replay_rules alone (no store, no read)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    parts, applied = history(args.parts)
    if args.engine_only:
        engine_only(parts, applied, args.rounds, Path(args.out or OUT.with_name("replay_year_engine.txt")))
        return
    args.out = args.out or str(OUT)
    ref = svd_seconds()
    lines = [
        f"# bench/replay_year.py --parts {args.parts} --rounds {args.rounds}",
        f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, load "
        f"{os.getloadavg()[0]:.1f}",
        f"reference (same run): best of 5 SVDs of 1000 × 300 = {ref:.4f} s",
        f"history: {args.parts} parts × 28 dimensions, {int(np.any(np.diff(applied, axis=0) != 0, axis=1).sum())} "
        "corrections logged",
        "",
        f"{'store':<12}{'fill s':>8}{'read s':>9}{'(×ref)':>9}{'replay s':>10}{'(×ref)':>9}{'grid s':>9}"
        f"{'(×ref)':>9}{'rule sets':>10}",
    ]
    print("\n".join(lines), flush=True)
    with tempfile.TemporaryDirectory() as folder:
        stores = [("sqlite", str(Path(folder) / "year.db"))] + ([("postgresql", args.db)] if args.db else [])
        for name, location in stores:
            t0 = time.perf_counter()
            fill(location, parts, applied)
            filled = time.perf_counter() - t0
            model = load_model(MODEL)
            from setupfix.inputs.stores import StoreRef

            ref_store = StoreRef(location, "year")
            read = best(lambda: load_series(model, db=ref_store), args.rounds)  # noqa: B023
            one = ReplayRequest(ref_store, model, USED)
            replay = best(lambda: replay_history(one), args.rounds)  # noqa: B023
            outcome = replay_history(one)
            grid = math.nan
            if args.grid:
                grid = best(lambda: replay_history(ReplayRequest(ref_store, model, USED, grid=True)), 1)  # noqa: B023
            same = outcome.replayed == outcome.actual
            line = (
                f"{name:<12}{filled:>8.1f}{read:>9.2f}{read / ref:>9.0f}{replay:>10.2f}{replay / ref:>9.0f}"
                f"{grid:>9.1f}{grid / ref:>9.0f}{36 if args.grid else 0:>10}"
            )
            lines.append(line)
            print(line, flush=True)
            lines.append(f"  the rule used, replayed, gives back what happened: {same}")
    Path(args.out).write_text("\n".join(lines) + "\n")


def engine_only(parts: np.ndarray, applied: np.ndarray, rounds: int, out: Path) -> None:
    """:func:`replay_rules` alone over the history (the rule used), best of ``rounds``, as a ratio to the reference."""
    model = load_model(MODEL)
    c = relation_matrices(model).composite
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    ref = svd_seconds()
    seconds = best(lambda: replay_rules(parts, applied, c, lower, upper, model.resolution, USED), rounds)
    same = np.array_equal(replay_rules(parts, applied, c, lower, upper, model.resolution, USED).deviation, parts)
    lines = [
        f"# bench/replay_year.py --engine-only --parts {len(parts)} --rounds {rounds}",
        f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, load "
        f"{os.getloadavg()[0]:.1f}",
        f"reference (same run): best of 5 SVDs of 1000 × 300 = {ref:.4f} s",
        f"replay_rules over {len(parts)} parts × {parts.shape[1]} dimensions: best {seconds:.2f} s "
        f"({seconds / ref:.1f} × the reference); the rule used gives back the parts: {same}",
    ]
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
