"""Declared design factors (``diagnose --factors``): the plate's experiment as stated, false alarms, detection.

A. The NIST plate with its process log, the experiment declared (doe_tool_length, doe_speed and their
   interaction): each term per cutter register, the part as the cluster (multi-column cluster-robust Wald
   test), Holm over the 15 declared tests; beside it the pre-specified 2 x 3 factorial on part means
   (bench/diagnosis.py).  The diagnosis with and without the declaration: residual, out of
   tolerance, walk forward.
B. No real effect, the plate: the log's rows (every channel together, so the design stays a 2 x 3 with
   the operator's parts) dealt to the parts at random (seeded permutations): share with any declared
   test accepted (family-wise; nominal <= alpha = 0.01) and share of single tests accepted.
C. No real effect, simulated: the guide pins (28 dimensions, cell noise 0.002 mm), a random balanced 2 x 3
   design over the parts (18 and 40 parts), shared per-part noise 0 and 2x the cell noise: the same rates.
D. Detection: one cell of the design (A = hi, B = hi) off by a magnitude on one tool, 18 parts: share of
   seeds with the interaction accepted on that tool (and nothing on another).
E. Speed: diagnose with the walk forward, with and without the declaration.
The declared tests: the multi-column cluster-robust Wald test with each part's residual corrected for its
leverage (CR2) and Bell-McCaffrey degrees of freedom (setupfix/diagnose/inference.py, cluster_wald with Q).

    python -m bench.diagnose_factors [series per setting, default 300]   # writes bench/results/diagnose_factors.txt
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]

from bench.diagnose_calibration import rate
from bench.diagnosis import NOISE, PLATE, PLATE_LOG, PLATE_MODEL, guide_pins, simulate, speed_tests
from setupfix.diagnose import Diagnoser, Layout, factor_tests, parse_terms
from setupfix.diagnose.terms import channel_values
from setupfix.inputs.series import load_series
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports

OUT = ROOT / "bench" / "results" / "diagnose_factors.txt"
DESIGN = ("doe_tool_length", "doe_speed", "doe_tool_length*doe_speed")
SIM = parse_terms(("A", "B", "A*B"))


def design_series(layout: Layout, seed: int, n: int, part_noise: float):
    """A null series with a random balanced 2 x 3 design in its process log (the log reader's channels)."""
    s = simulate(layout, seed=seed, n_cycles=n, part_noise=part_noise).series
    rng = np.random.default_rng(seed)
    cells = rng.permutation(np.arange(n) % 6)
    a, b = cells // 3, cells % 3
    names = ("A=hi", "B=lo", "B=mid", "B=hi")
    cols = np.column_stack([a == 1] + [b == k for k in range(3)]).astype(float)
    return dataclasses.replace(
        s, temperature=np.column_stack([s.temperature, cols]), channels=(*s.channels, *names), process_channels=names
    )


def main(n_series: int) -> None:
    lines: list[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    t0 = time.perf_counter()
    say(__doc__.split("\n\n    python")[0])
    say()
    inp = load_series(PLATE_MODEL, (PLATE,), process=str(PLATE_LOG))
    terms = parse_terms(DESIGN)
    ft = factor_tests(inp.layout, inp.series, terms)
    indep = {r["register"]: r for r in speed_tests(inp.layout, inp.series)}
    say(
        "A. the plate, declared: per-part p (Holm-adjusted over the 15 tests), and the 2 x 3 factorial on part "
        "means (interaction, 2 and 12 df)"
    )
    say(f"  {'term':<28}{'register':<10}{'columns':>8}{'p':>11}{'Holm':>11}  {'accepted':<9}{'factorial':>11}")
    for t in ft.tests:
        ref = f"{float(indep[t.register]['p_interaction']):.2g}" if t.term.order == 2 else ""
        say(
            f"  {t.term.name:<28}{t.register:<10}{t.q:>8}{t.p:>11.2g}{t.p_holm:>11.2g}  "
            f"{'yes' if t.accepted else 'no':<9}{ref:>11}"
        )
    loose = factor_tests(inp.layout, inp.series, terms, alpha=0.05)
    say("  accepted at alpha = 0.05: " + ", ".join(f"{t.term.name} on {t.register}" for t in loose.tests if t.accepted))
    for label, factors in (("without --factors", ()), ("with --factors", (",".join(DESIGN),))):
        t = time.perf_counter()
        d = diagnose_reports(  # the search alone without the declaration (the log family: diagnose_log_family)
            DiagnoseRequest(
                PLATE_MODEL, (PLATE,), process=str(PLATE_LOG), factors=factors, diagnoser=Diagnoser(log_first=False)
            )
        ).diagnosis
        dt = time.perf_counter() - t
        w = d.walk.budgets if d.walk is not None else {}
        say(
            f"  {label}: residual RMS {d.error_before.rms:.4f} -> {d.error_after.rms:.4f} mm, out of tolerance "
            f"{d.error_before.out_of_tolerance} -> {d.error_after.out_of_tolerance}; "
            f"{sum(e.source == 'declared' for e in d.effects)} declared + "
            f"{sum(e.source == 'search' for e in d.effects)} searched effect terms; walk forward centre RMS "
            + ", ".join(f"{k} {b.centre_rms:.4f} ({b.out_of_tolerance} out)" for k, b in w.items())
            + f"; next from {d.next_from.source}; {dt:.1f} s"
        )
        for e in d.effects:
            if e.source == "search":
                say(f"    found by the search: {e.target} {e.estimate:+.4g} +- {e.stderr:.2g} {e.unit}")
    say()
    say(f"B. the plate's log rows permuted across whole parts, {n_series} permutations, alpha = 0.01")
    anyf = single = 0
    for seed in range(n_series):
        perm = np.random.default_rng(seed).permutation(inp.series.n_cycles)
        s = dataclasses.replace(inp.series, temperature=inp.series.temperature[perm])
        res = factor_tests(inp.layout, s, terms)
        hits = sum(t.accepted for t in res.tests)
        anyf += hits > 0
        single += hits
    say(
        f"  any declared test accepted: {rate(anyf, n_series)}; single tests accepted: "
        f"{rate(single, n_series * len(ft.tests))}"
    )
    say()
    layout = Layout.from_model(guide_pins())
    say(
        f"C. simulated, nothing hidden (guide pins, random balanced 2 x 3 design: A, B, A*B on "
        f"{len(layout.tools)} tools = {3 * len(layout.tools)} tests), {n_series} series per setting, alpha = 0.01"
    )
    say(f"  {'parts':>6}{'shared / cell noise':>22}  {'any declared test accepted':<32}  single tests accepted")
    for n in (18, 40):
        for f in (0.0, 2.0):
            anyf = single = total = 0
            for seed in range(n_series):
                s = design_series(layout, 7000 + seed, n, f * NOISE)
                res = factor_tests(layout, s, SIM)
                hits = sum(t.accepted for t in res.tests)
                anyf += hits > 0
                single += hits
                total += len(res.tests)
            say(f"  {n:>6}{f:>22g}  {rate(anyf, n_series):<32}  {rate(single, total)}")
    say()
    n_det = max(10, n_series // 5)
    say(
        f"D. detection, 18 parts: the cell A = hi, B = hi off on tool {layout.tool_ids[0]}, {n_det} seeds: share "
        "with A*B accepted on it (and no declared term on another tool)"
    )
    say(f"  {'magnitude [mm]':>15}  {'no shared noise':<32}  shared noise 2x")
    j = int(layout.tools[0])
    for mag in (0.0025, 0.005, 0.01, 0.02):
        cells = []
        for f in (0.0, 2.0):
            hits = 0
            for seed in range(n_det):
                s = design_series(layout, 8000 + seed, 18, f * NOISE)
                cell = channel_values(s, "A=hi & B=hi")
                s = dataclasses.replace(s, deviation=s.deviation + mag * np.outer(cell, layout.composite[j]))
                acc = {(t.term.name, t.register) for t in factor_tests(layout, s, SIM).tests if t.accepted}
                hits += ("A*B", layout.register_ids[j]) in acc and all(r == layout.register_ids[j] for _, r in acc)
            cells.append(rate(hits, n_det))
        say(f"  {mag:>15g}  {cells[0]:<32}  {cells[1]}")
    say()
    say(
        "E. speed: diagnose with the walk forward (guide pins, 28 dimensions, the 2 x 3 design, shared noise 2x; "
        "BLAS 1), best of 3 (1 for 1,000 cycles)"
    )
    for n, reps in ((40, 3), (1000, 1)):
        s = design_series(layout, 1, n, 2 * NOISE)
        cells = []
        for factors in ((), SIM):
            best = np.inf
            for _ in range(reps):
                t = time.perf_counter()
                Diagnoser().run(layout, s, factors=factors)
                best = min(best, time.perf_counter() - t)
            cells.append(f"{best:.2f} s")
        say(f"  {n:>5} cycles: without factors {cells[0]}, with A, B, A*B declared {cells[1]}")
    say()
    say(f"total {time.perf_counter() - t0:.0f} s")
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    with threadpool_limits(1):
        main(int(sys.argv[1]) if len(sys.argv) > 1 else 300)
