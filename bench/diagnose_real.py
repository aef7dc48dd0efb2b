"""The diagnosis on the real NIST MTC series (issue 24): the plate and the box, and shuffled timestamps.

Data: ``cmm-samples/qif/NIST_MTC_FAIR_{Plate,Box}_Results_*.qif`` with the machining logs of
``real-series/nist-mtc/`` (timestamps per serial, the plate's designed factors).  Models:
``tests/data/nist_plate.toml`` (a register per cutter and hole pattern, W1 for the distances) and
``tests/diagnose/data/nist_box.toml`` (the scaffold of the box report).

A. Each series without and with its process log: residual before / after (RMS, out of
   tolerance), the effects named, where the next correction comes from and the walk forward's
   centre RMS of the augmented model and of EWMA.
B. Shuffled timestamps: the plate's machining times (from its log) dealt to the parts at random
   (seeded permutations), without the process log: a diagnosis that names a time-dependent
   effect (drift, thermal, wear, level) on shuffled times is a false alarm, since whatever the
   parts differ by no longer follows time.  The same for the box.

    python bench/diagnose_real.py [shuffles]     # writes bench/results/diagnose_real.txt
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from setupfix.diagnose import Diagnoser, select_effects
from setupfix.pipeline.series import load_series

SHARED = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent.parent / "shared"))
if not (SHARED / "real-series").is_dir():
    SHARED = Path("/work/shared")
OUT = ROOT / "bench" / "results" / "diagnose_real.txt"
SERIES = {
    "plate": (ROOT / "tests" / "data" / "nist_plate.toml",
              SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif",
              SHARED / "real-series" / "nist-mtc" / "plate_process.csv"),
    "box": (ROOT / "tests" / "diagnose" / "data" / "nist_box.toml",
            SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Box_Results_19parts.qif",
            SHARED / "real-series" / "nist-mtc" / "box_process.csv"),
}
TIME_KINDS = ("drift", "thermal", "wear", "level")


def shuffled(series, seed: int):
    """The series with its parts' times permuted (seeded), every other covariate kept with its part."""
    perm = np.random.default_rng(seed).permutation(series.n_cycles)
    return dataclasses.replace(series, time=series.time[perm])


def without_process(series):
    """The series with the process channels dropped (times kept)."""
    keep = [i for i, c in enumerate(series.channels) if c not in series.process_channels]
    return dataclasses.replace(series, temperature=series.temperature[:, keep],
                               channels=tuple(series.channels[i] for i in keep), process_channels=())


def main(n_shuffles: int) -> None:
    lines: list[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    t0 = time.perf_counter()
    say(__doc__.split("\n\n    python")[0])
    say()
    say("A. the series as they are (machining times from the process log, joined by serial)")
    for name, (model, qif, log) in SERIES.items():
        inp = load_series(model, (qif,), process=str(log))
        for label, series in (("without log", without_process(inp.series)), ("with log", inp.series)):
            d = Diagnoser().run(inp.layout, series)
            b = d.walk.budgets if d.walk is not None else {}
            say(f"{name} {label}: {series.n_cycles} parts, RMS {d.error_before.rms:.4f} -> {d.error_after.rms:.4f} mm, "
                f"out of tolerance {d.error_before.out_of_tolerance} -> {d.error_after.out_of_tolerance}; "
                f"next from {d.next_from.source}"
                + (f"; walk centre RMS augmented {b['augmented'].centre_rms:.4f}, ewma {b['ewma'].centre_rms:.4f}"
                   if b else ""))
            for e in d.effects:
                say(f"    {e.kind:8s} {e.target}  {e.estimate:+.4g} ± {e.stderr:.2g} {e.unit}")
            if not d.effects:
                say("    no effect named")
    say()
    say(f"B. shuffled timestamps, {n_shuffles} seeded permutations per series (seeds 0..{n_shuffles - 1}), "
        "no process log: series with a time-dependent effect named")
    for name, (model, qif, log) in SERIES.items():
        base = without_process(load_series(model, (qif,), process=str(log)).series)
        inp = load_series(model, (qif,), process=str(log))
        hits = []
        for seed in range(n_shuffles):
            sel = select_effects(inp.layout, shuffled(base, seed))
            named = [s.target for s in sel.found if s.kind in TIME_KINDS]
            if named:
                hits.append(f"seed {seed}: {', '.join(named)}")
        say(f"{name}: {len(hits)} of {n_shuffles}" + ("" if not hits else "  (" + "; ".join(hits) + ")"))
    say()
    say(f"total {time.perf_counter() - t0:.0f} s")
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
