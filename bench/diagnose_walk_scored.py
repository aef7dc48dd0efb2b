"""Walk forward scored apart from its learning: where does the next correction come from?

Guide pins, 80 cycles, a hidden wear of one tool (−0.001 mm/cycle × scale), shared per-part
noise 2× the cell noise, seeds 0–7.  For each series: the effects the diagnosis finds, the
cycle from which the walk's choice is stable, and the source of the next correction judged
on the whole walk (the rule before issue 41) and on the scored part (now), with the centre
RMS of the augmented model and EWMA on each.

Run: ``python -m bench.diagnose_walk_scored`` → ``bench/results/diagnose_walk_scored.txt``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from bench.diagnosis import NOISE, guide_pins, one_effect, simulate
from setupfix.diagnose import Diagnoser, Layout
from setupfix.diagnose.walk import WalkForward, next_source

SCALES = (1.0, 0.5, 0.4)
SEEDS = range(8)


def whole_source(walk: WalkForward) -> str:
    """The next correction's source as the whole walk judges it (learning period scored)."""
    if walk.whole is None:
        return next_source(walk, True).source
    return next_source(WalkForward(walk.walked, walk.whole), True).source


def main() -> None:
    layout = Layout.from_model(guide_pins(positions=False))
    lines = [
        "Walk forward scored apart from learning (bench/diagnose_walk_scored.py): guide pins, 80 cycles,",
        "wear of T5 -0.001 mm/cycle x scale, shared per-part noise 2x the cell noise 0.002 mm.",
        "",
        f"{'scale':>5} {'seed':>4} {'found':>6} {'stable':>6} {'whole: next':>12} {'aug':>8} {'ewma':>8} "
        f"{'scored: next':>13} {'aug':>8} {'ewma':>8}",
    ]
    totals = {s: [0, 0, 0] for s in SCALES}
    for scale in SCALES:
        for seed in SEEDS:
            hidden = one_effect(layout, "wear", scale)
            sim = simulate(layout, [hidden], seed=seed, part_noise=2 * NOISE, n_cycles=80)
            d = Diagnoser().run(layout, sim.series)
            w = d.walk
            assert w is not None
            whole = w.whole or w.budgets
            found = any(e.spec == hidden.spec for e in d.effects)
            before = whole_source(w)
            totals[scale][0] += int(found)
            totals[scale][1] += int(found and before == "augmented")
            totals[scale][2] += int(found and d.next_from.source == "augmented")
            lines.append(
                f"{scale:>5} {seed:>4} {'yes' if found else 'no':>6} "
                f"{(w.scored_from or w.walked[0]) + 1:>6} {before:>12} {whole['augmented'].centre_rms:>8.5f} "
                f"{whole['ewma'].centre_rms:>8.5f} {d.next_from.source:>13} "
                f"{w.budgets['augmented'].centre_rms:>8.5f} {w.budgets['ewma'].centre_rms:>8.5f}"
            )
    lines.append("")
    for scale, (n_found, n_before, n_after) in totals.items():
        lines.append(
            f"scale {scale}: wear found in {n_found} of {len(SEEDS)}; next correction from it "
            f"{n_before} of {len(SEEDS)} judged on the whole walk, {n_after} of {len(SEEDS)} on the scored part"
        )
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    (Path(__file__).parent / "results" / "diagnose_walk_scored.txt").write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
