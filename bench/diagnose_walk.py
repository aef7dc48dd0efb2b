"""Bench: the walk forward as a shop scores it, and where the next correction comes from (issue 24).

A. Simulated guide-pins series (40 × 28, 8 seeds each): a hidden drift or wear (the augmented model should earn
   the next correction), nothing hidden, and a WKS wandering as a random walk (an effect is found in hindsight,
   EWMA tracks it better).  Per case: walk-forward distance to the tolerance centre (RMS) of the declared model,
   the augmented model and EWMA, out-of-tolerance cells, and how often the next correction comes from each model.
B. The real NIST MTC plate (20 parts, model tests/data/nist_plate.toml; parts in machining
   order, times from ../shared/real-series/nist-mtc/plate_process.csv when present): the walk's numbers, the
   verdict, the registers the centre rule holds and the next correction.
C. Speed: ``diagnose`` of 40 × 28 with the walk forward and the next correction (correct_cycle), best of 5,
   BLAS threads 1, as a ratio to a reference timed in the same run (SVD of a 1000 × 300 matrix).

Run: ``SETUPFIX_SHARED=../shared python -m bench.diagnose_walk`` → bench/results/diagnose_walk.txt
"""

from __future__ import annotations

import dataclasses
import time
from collections import Counter
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from bench.diagnosis import PLATE, PLATE_LOG, PLATE_MODEL, guide_pins, one_effect, simulate, svd_seconds
from setupfix.diagnose import Diagnoser, Layout
from setupfix.inputs.series import load_series
from setupfix.usecases.diagnosis import recommend_next

OUT = ROOT / "bench" / "results" / "diagnose_walk.txt"
MODEL = guide_pins(positions=False)
LAYOUT = Layout.from_model(MODEL)


def random_walk(seed: int, step: float = 0.004):
    s = simulate(LAYOUT, seed=seed, correct_every=0).series
    wander = np.zeros((s.n_cycles, LAYOUT.n_registers))
    wander[:, 0] = np.cumsum(np.random.default_rng(seed).normal(0, step, size=s.n_cycles))
    return dataclasses.replace(s, deviation=np.round(s.deviation + wander @ LAYOUT.composite, 4))


def section_a(lines: list[str]) -> None:
    lines += [
        "A. simulated, guide pins 40 x 28, 8 seeds: walk forward distance to the tolerance centre, RMS [mm]",
        "   (median over seeds), out-of-tolerance cells (sum), and where the next correction came from",
        f"{'hidden':<12} {'declared':>9} {'augmented':>10} {'EWMA':>9} {'OOT d/a/e':>12}  next from",
    ]
    cases = {
        "none": lambda s: simulate(LAYOUT, seed=s).series,
        "drift": lambda s: simulate(LAYOUT, [one_effect(LAYOUT, "drift")], seed=s).series,
        "wear": lambda s: simulate(LAYOUT, [one_effect(LAYOUT, "wear")], seed=s).series,
        "random walk": random_walk,
    }
    for name, make in cases.items():
        rms = {k: [] for k in ("declared", "augmented", "ewma")}
        oot = Counter()
        came = Counter()
        for seed in range(8):
            d = Diagnoser().run(LAYOUT, make(seed))
            for k in rms:
                rms[k].append(d.walk.budgets[k].centre_rms)
                oot[k] += d.walk.budgets[k].out_of_tolerance
            came[d.next_from.source] += 1
        lines.append(
            f"{name:<12} {np.median(rms['declared']):9.4f} {np.median(rms['augmented']):10.4f} "
            f"{np.median(rms['ewma']):9.4f} {oot['declared']:>4}/{oot['augmented']}/{oot['ewma']:<5}  "
            + ", ".join(f"{k} {v}" for k, v in sorted(came.items()))
        )
    lines.append("")


def section_b(lines: list[str]) -> None:
    import pandas as pd

    inp = load_series(PLATE_MODEL, (PLATE,))
    series = inp.series
    timed = PLATE_LOG.is_file()
    if timed:
        log = pd.read_csv(PLATE_LOG)
        stamps = pd.to_datetime(log["timestamp"])
        series = dataclasses.replace(
            series,
            time=((stamps - stamps.iloc[0]).dt.total_seconds() / 3600).to_numpy(),
            origin=str(log["timestamp"].iloc[0]),
        )
    d = Diagnoser().run(inp.layout, series)
    cycle, _ = recommend_next(inp.model, d)
    lines += [
        f"B. NIST MTC plate, {series.n_cycles} parts, model tests/data/nist_plate.toml, "
        f"{'machining times from plate_process.csv' if timed else 'cycle order (no times)'}",
        f"   effects found: {', '.join(e.target for e in d.effects) or 'none'}",
        f"   walk forward over {len(d.walk.cycles) if d.walk else 0} part(s):",
        f"   {'model':<10} {'centre RMS':>10} {'centre |.|':>10} {'OOT':>5} {'budget mean':>12}",
    ]
    assert d.walk is not None
    for name, b in d.walk.budgets.items():
        lines.append(
            f"   {name:<10} {b.centre_rms:10.4f} {b.centre_mean_abs:10.4f} {b.out_of_tolerance:5d} "
            f"{b.mean_budget:+12.4f}"
        )
    held = [r for r, h in zip(inp.layout.register_ids, d.centred if d.centred is not None else [], strict=True) if h]
    lines += [
        f"   next from: {d.next_from.source} -- {d.next_from.reason}",
        f"   held by the centre rule: {', '.join(held) or 'none'}",
        "   next correction: "
        + (", ".join(f"{k} {v:+.3f}" for k, v in cycle.corrections.items()) if cycle is not None else "none"),
        "",
    ]


def section_c(lines: list[str]) -> None:
    ref = svd_seconds()
    lines += [
        "C. speed (guide pins 40 x 28, wear hidden; best of 5; BLAS threads 1)",
        f"   reference: SVD of a 1000 x 300 matrix = {ref * 1000:.1f} ms",
    ]
    for label, make in (
        ("wear (next from augmented)", lambda: simulate(LAYOUT, [one_effect(LAYOUT, "wear")], seed=1).series),
        ("random walk (next from EWMA)", lambda: random_walk(5)),
    ):
        series = make()
        best = {"walk": np.inf, "walk + next": np.inf}
        for _ in range(5):
            t0 = time.perf_counter()
            d = Diagnoser().run(LAYOUT, series)
            t1 = time.perf_counter()
            recommend_next(MODEL, d)
            t2 = time.perf_counter()
            best["walk"] = min(best["walk"], t1 - t0)
            best["walk + next"] = min(best["walk + next"], t2 - t0)
        for k, v in best.items():
            lines.append(f"   {label:<30} {k:<12}: {v:6.3f} s = {v / ref:6.1f} x reference (target <= 2 s)")
    lines.append("")


def main() -> None:
    t0 = time.perf_counter()
    lines = ["python -m bench.diagnose_walk", ""]
    with threadpool_limits(limits=1):
        for section in (section_a, section_b, section_c):
            start = len(lines)
            section(lines)
            print("\n".join(lines[start:]), flush=True)
    lines.append(f"total {time.perf_counter() - t0:.0f} s")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
