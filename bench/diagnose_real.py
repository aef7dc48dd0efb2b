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
C. The plate's second designed factor, the spindle speed: (1) the experiment analysed with the
   part as the unit and the hypothesis stated in advance (``bench/diagnosis.py``: the
   2 x 3 factorial with three parts per cell, and the slope on the logged speed within the long
   stick-out); (2) the same stick-out x speed term tested per part as the diagnosis tests a
   one-column candidate, in the model it found, against the threshold its search must meet
   (alpha over the candidates of the step); (3) the speed's effect scaled by k (0: removed, 2, 4)
   in the measured deviations: what the diagnosis names then.
D. The residual: the diagnosis's model, with the stick-out x speed term added per cutter register,
   and the per-cutter model on the same channels (a constant and coefficients per dimension, the
   0.025 mm the issue quotes).

    python -m bench.diagnose_real [shuffles]     # writes bench/results/diagnose_real.txt
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

from bench.diagnosis import LONG, RPM, channel, residual_rms, speed_term, speed_term_pvalues, speed_tests
from setupfix.diagnose import Diagnoser, EffectSpec, select_effects
from setupfix.inputs.series import load_series

SHARED = Path(os.environ.get("SETUPFIX_SHARED", ROOT.parent.parent / "shared"))
if not (SHARED / "real-series").is_dir():
    SHARED = Path("/work/shared")
OUT = ROOT / "bench" / "results" / "diagnose_real.txt"
SERIES = {
    "plate": (
        ROOT / "tests" / "data" / "nist_plate.toml",
        SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif",
        SHARED / "real-series" / "nist-mtc" / "plate_process.csv",
    ),
    "box": (
        ROOT / "tests" / "diagnose" / "data" / "nist_box.toml",
        SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Box_Results_19parts.qif",
        SHARED / "real-series" / "nist-mtc" / "box_process.csv",
    ),
}
TIME_KINDS = ("drift", "thermal", "wear", "level")


def shuffled(series, seed: int):
    """The series with its parts' times permuted (seeded), every other covariate kept with its part."""
    perm = np.random.default_rng(seed).permutation(series.n_cycles)
    return dataclasses.replace(series, time=series.time[perm])


def without_process(series):
    """The series with the process channels dropped (times kept)."""
    keep = [i for i, c in enumerate(series.channels) if c not in series.process_channels]
    return dataclasses.replace(
        series,
        temperature=series.temperature[:, keep],
        channels=tuple(series.channels[i] for i in keep),
        process_channels=(),
    )


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
            say(
                f"{name} {label}: {series.n_cycles} parts, RMS {d.error_before.rms:.4f} -> {d.error_after.rms:.4f} mm, "
                f"out of tolerance {d.error_before.out_of_tolerance} -> {d.error_after.out_of_tolerance}; "
                f"next from {d.next_from.source}"
                + (
                    f"; walk centre RMS augmented {b['augmented'].centre_rms:.4f}, ewma {b['ewma'].centre_rms:.4f}"
                    if b
                    else ""
                )
            )
            for e in d.effects:
                say(f"    {e.kind:8s} {e.target}  {e.estimate:+.4g} ± {e.stderr:.2g} {e.unit}")
            if not d.effects:
                say("    no effect named")
    say()
    say(
        f"B. shuffled timestamps, {n_shuffles} seeded permutations per series (seeds 0..{n_shuffles - 1}), "
        "no process log: series with a time-dependent effect named"
    )
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
    plate_speed(say)
    say()
    say(f"total {time.perf_counter() - t0:.0f} s")
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")


def plate_speed(say) -> None:
    """Sections C and D (module text)."""
    model, qif, log = SERIES["plate"]
    inp = load_series(model, (qif,), process=str(log))
    layout, series = inp.layout, inp.series
    say("C. the plate's second designed factor: the spindle speed")
    say("C1. the part as the unit, one hypothesis stated in advance (18 parts of the experiment; per part the mean")
    say("    of the dimensions each cutter register alone moves; nested OLS F-tests; within the 9 long stick-out")
    say("    parts the slope on the logged speed)")
    say(
        f"{'register':>10}  {'speed, any (4, 12 df)':>22}  {'stick-out x speed (2, 12 df)':>29}  "
        f"{'slope on long [mm/1000 rpm]':>28}  {'t':>6}  {'p (7 df)':>9}"
    )
    for row in speed_tests(layout, series):
        say(
            f"{row['register']:>10}  {row['p_speed']:>22.2g}  {row['p_interaction']:>29.2g}  {row['slope']:>+28.4f}  "
            f"{row['t']:>6.2f}  {row['p_slope']:>9.2g}"
        )
    sel = select_effects(layout, series)
    stick = str(sel.found[0].channel)
    m = sel.steps[-1].tested
    alpha = 0.01
    say("C2. the same term as the diagnosis tests a one-column candidate (cluster-robust, the part as the cluster,")
    say(f"    small-sample df), in the model it found; its last step tried m = {m} candidates, so a claim needs")
    say(f"    p < alpha / m = {alpha / m:.2g}")
    ref = float(f"{series.temperature[:, series.channels.index(LONG)].mean():.4g}")
    tools = tuple(layout.register_ids[j] for j in layout.tools)
    every_long = tuple(EffectSpec("process", channel=LONG, register=r, reference=ref) for r in tools)
    cases = (
        (f"the stick-out found ({stick})", sel.found, stick),
        (f"the stick-out on every long part ({LONG}), a coefficient per cutter", every_long, LONG),
    )
    for label, found, ch in cases:
        ps = speed_term_pvalues(layout, series, found, ch)
        say(f"    {speed_term(series, ch)[0]} after {label}:")
        say("      " + ", ".join(f"{r} p = {p:.2g} (x m = {min(1.0, p * m):.2g})" for r, p in ps.items()))
    say("    Not claimed.  The speed acts only with the long stick-out, so its evidence is the nine long parts, and")
    say("    within them the parts at 6000 and 12000 rpm (six parts: the test's df is 5).  The candidates the search")
    say("    has cannot hold it better: a stick-out x speed-level indicator is on three parts, the speed channel")
    say(f"    alone ({RPM}) acts on the short parts too; a per-register set of five coefficients on nine parts has no")
    say("    df left (Hotelling's df = effective parts - 5 + 1 < 1).  Pre-specified (C1) the speed is plain; as the")
    say("    result of a search over every channel, register and level position at family-wise alpha with the part")
    say("    as the unit, it is not.")
    say("C3. the speed's effect scaled by k in the measured deviations (the within-long slopes of C1): what the")
    say("    diagnosis names, and the term's smallest per-part p (after the stick-out on every long part) against")
    say(f"    alpha / m = {alpha / m:.2g}")
    contrib = _speed_contribution(layout, series)
    for k in (0.0, 1.0, 1.5, 2.0, 4.0):
        s = dataclasses.replace(series, deviation=series.deviation + (k - 1.0) * contrib)
        found = [st.target for st in select_effects(layout, s).steps if st.accepted]
        best = min(speed_term_pvalues(layout, s, every_long, LONG).items(), key=lambda x: x[1])
        term = f"  [term: {best[0]} p = {best[1]:.2g}]" if k else ""
        say(f"    k = {k:g}: {'; '.join(found) or 'nothing named'}{term}")
    say("    Without the speed (k = 0) the stick-out is named on all nine long parts; with it the channel of parts")
    say("    11-18 explains more (part 10, a long part at 12000 rpm, sits low), which is why the diagnosis names")
    say("    that one.  Were the stick-out x speed term a candidate of the search, it would pass its per-part test")
    say("    at about twice the speed effect the plate shows (k = 2); no candidate the search has carries it, so")
    say("    a larger speed effect still goes unnamed and the named stick-out thins out (k = 2, 4).")
    say()
    say("D. residual RMS of the plate with its log [mm] (the issue quotes 0.025 for a per-cutter model)")
    rows = [
        ("declared model (a constant per register)", residual_rms(layout, series, ())),
        (f"the diagnosis: + {stick} per cutter", residual_rms(layout, series, sel.found)),
        ("  + the stick-out x speed term per cutter register", residual_rms(layout, series, sel.found, stick)),
        (f"{LONG} + the stick-out x speed term per cutter register", residual_rms(layout, series, every_long, LONG)),
        (f"a constant per dimension, {LONG} per dimension", residual_rms(layout, series, (), None, True)),
        (
            "  + the stick-out x speed term per dimension (the per-cutter model)",
            residual_rms(layout, series, (), LONG, True),
        ),
    ]
    for label, v in rows:
        say(f"    {label:<78s} {v:.4f}")
    say("    The gap from the diagnosis's 0.061 to 0.025 is the speed (C2: not claimed) and a constant and")
    say("    coefficients per dimension where the model has one per register (the holes of one pattern differ")
    say("    by more than the noise: the lack of fit).")


def _speed_contribution(layout, series) -> np.ndarray:
    """The stick-out x speed term with the within-long slope of C1 per register: (n_cycles, n_dimensions)."""
    slope = {row["register"]: float(row["slope"]) for row in speed_tests(layout, series)}
    on = channel(series, LONG)
    a = on * (channel(series, RPM) / 1000.0 - 9.0)
    out = np.zeros_like(series.deviation)
    for j in layout.tools:
        rid = layout.register_ids[j]
        if rid in slope:
            out += np.outer(a, layout.composite[j]) * slope[rid]
    return out


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
