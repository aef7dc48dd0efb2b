"""The process log as the user's family of hypotheses (issue 41 item 4): the NIST plate and calibration.

The log of the issue: the plate's own conditions as numeric columns (long_tool 0/1, rpm_deficit = 12000 rpm
minus the end mill's speed, long_x_slow 0/1) plus decoys drawn at random per part from a seed (coolant_c,
operator, batch_age_h, vice_torque, chip_bin), given with --process and no --factors.

A. Why not the declared factors' test: every column at once, type II, the cluster-robust Wald test (CR2,
   Bell-McCaffrey df) with Holm over the columns x registers: the stick-out x speed column on T5A.
B. The diagnosis (walk forward on) without and with the log family first, the issue's log (decoy seeds 0-4)
   and the plate's own log: residual RMS, out of tolerance, first effect, decoys named, walk forward centre
   RMS of the augmented model and EWMA (scored part), next correction's source; time as a ratio.
C. No real effect: the log's rows dealt to the parts at random (seeded permutations): share of runs in which
   the family accepts anything (alpha = 0.01; the issue asks <= 5 %), for the issue's log and the plate's own.

    python -m bench.diagnose_log_family [permutations, default 200]   # writes bench/results/diagnose_log_family.txt
"""

from __future__ import annotations

import csv
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench.diagnosis import PLATE, PLATE_LOG, PLATE_MODEL
from setupfix.diagnose import Diagnoser, factor_tests
from setupfix.diagnose.log_family import log_factors, log_family
from setupfix.inputs.series import load_series
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results" / "diagnose_log_family.txt"

#: The plate's conditions as the issue's log names them.
CAUSES = ("long_tool", "rpm_deficit", "long_x_slow")
#: Columns with no relation to the parts (drawn per part from the seed).
DECOYS = ("coolant_c", "operator", "batch_age_h", "vice_torque", "chip_bin")


def plate_log(target: Path, seed: int = 0, source: Path = PLATE_LOG) -> Path:
    """Write the issue's log for the plate: :data:`CAUSES` from the plate's own log, :data:`DECOYS` at random."""
    with source.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    rng = np.random.default_rng(seed)
    out = []
    for r in rows:
        long = int(r["doe_tool_length"] == "Long")
        out.append(
            {
                "serial": r["serial"],
                "long_tool": long,
                "rpm_deficit": 12000 - float(r["endmill_rpm"]),
                "long_x_slow": long * int(r["doe_speed"] == "Low"),
                "coolant_c": round(float(rng.normal(20.0, 0.5)), 2),
                "operator": str(rng.choice(["Ann", "Bob"])),
                "batch_age_h": round(float(rng.uniform(0.0, 48.0)), 1),
                "vice_torque": round(float(rng.normal(60.0, 3.0)), 1),
                "chip_bin": int(rng.integers(0, 2)),
            }
        )
    with target.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(out[0]))
        w.writeheader()
        w.writerows(out)
    return target


def named_decoys(channels: list[str]) -> list[str]:
    """The decoy columns among effect channels (a product names each of its columns)."""
    return [c for c in channels if any(d in c for d in DECOYS)]


def main(n_perm: int) -> None:
    lines: list[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    say(__doc__.split("\n\n    python")[0])
    say()
    with tempfile.TemporaryDirectory() as tmp:
        log0 = plate_log(Path(tmp) / "log0.csv", 0)
        inp = load_series(PLATE_MODEL, (PLATE,), process=str(log0))
        mains = tuple(dataclasses.replace(t) for t in log_family(inp.layout, inp.series).terms)
        ft = factor_tests(inp.layout, inp.series, mains)
        say(f"A. every column at once, CR2 Wald, Holm over {len(ft.tests)} tests (columns x tool registers):")
        for t in sorted(ft.tests, key=lambda t: t.p)[:6]:
            say(f"  {t.term.name:<14}{t.register:<6} p {t.p:.2g}  Holm {t.p_holm:.2g}  accepted {t.accepted}")
        say()
        say("B. diagnose (walk forward on), residual RMS before -> after [mm], out of tolerance, walk centre RMS")
        for label, path in [(f"issue log, decoy seed {k}", plate_log(Path(tmp) / f"l{k}.csv", k)) for k in range(5)] + [
            ("the plate's own log", PLATE_LOG)
        ]:
            for first in (False, True):
                t0 = time.perf_counter()
                d = diagnose_reports(
                    DiagnoseRequest(PLATE_MODEL, (PLATE,), process=str(path), diagnoser=Diagnoser(log_first=first))
                ).diagnosis
                dt = time.perf_counter() - t0
                if not first:
                    ref = dt
                b = d.walk.budgets if d.walk is not None else {}
                head = d.effects[0].target if d.effects else "-"
                say(
                    f"  {label}, {'log family first' if first else 'search only    '}: "
                    f"{d.error_before.rms:.4f} -> {d.error_after.rms:.4f}, out {d.error_before.out_of_tolerance} -> "
                    f"{d.error_after.out_of_tolerance}; first: {head}; decoys named: "
                    f"{named_decoys([str(e.spec.channel) for e in d.effects]) or 'none'}; walk augmented "
                    f"{b['augmented'].centre_rms:.4f} vs ewma {b['ewma'].centre_rms:.4f}; next from "
                    f"{d.next_from.source}; time x{dt / ref:.2f} of search only"
                )
        say()
        say(f"C. the log's rows permuted across the parts, {n_perm} permutations each, alpha = 0.01")
        for label, path in (("issue log (seed 0)", log0), ("the plate's own log", PLATE_LOG)):
            inp = load_series(PLATE_MODEL, (PLATE,), process=str(path))
            s = inp.series
            claims = 0
            decoy = 0
            for seed in range(n_perm):
                perm = np.random.default_rng(10_000 + seed).permutation(s.n_cycles)
                res = log_family(inp.layout, dataclasses.replace(s, temperature=s.temperature[perm]), seed=seed)
                claims += bool(res.found)
                decoy += bool(named_decoys([str(x.channel) for x in res.found]))
            say(
                f"  {label} ({len(log_factors(s))} columns): runs with a claim {claims}/{n_perm} "
                f"({100 * claims / n_perm:.1f} %)"
            )
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
