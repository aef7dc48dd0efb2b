"""``setupfix simulate``: a closed-loop shop series with hidden effects, in the canonical formats."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.cli.choices import SIMULATE_START
from setupfix.cli.exit_codes import OK

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate a shop series (setup errors, noise, hidden effects, corrections)",
        description="Closed-loop shop simulator: true setup errors, measurement noise, hidden effects the "
        "model lacks, corrections applied every few cycles with a dead time, tool changes and a "
        "temperature log. Writes measurements.csv, corrections.csv, temperatures.csv and "
        "truth.json into OUT.",
    )
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write the series into")
    p.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="K=V,…",
        help="hidden effect, e.g. kind=drift,magnitude=0.002 | kind=drift,shape=saturating,tau=3,"
        "magnitude=0.02 | kind=thermal,magnitude=0.003 | kind=wear,register=T5,magnitude=-0.001 | "
        "kind=scale,magnitude=2e-4 | kind=position,axis=x,magnitude=1e-4 | "
        "kind=relation,register=T23,dimension=P2D3,magnitude=0.5 | kind=group,group=P3,"
        "magnitude=0.01 | kind=level,register=T5,at=20,magnitude=0.01 (a step from cycle 20 on) "
        "(repeatable)",
    )
    p.add_argument("--cycles", type=int, default=40, help="fixture cycles (default 40)")
    p.add_argument("--noise", type=float, default=0.002, help="measurement noise sigma, model unit (default 0.002)")
    p.add_argument("--setup-error", type=float, default=0.03, help="w1 of eq. 12: setup errors in ±w1 (0.03)")
    p.add_argument("--correct-every", type=int, default=5, help="cycles between corrections (0: never; 5)")
    p.add_argument("--dead-time", type=float, default=30.0, help="minutes from the last part to the correction (30)")
    p.add_argument("--tool-change-every", type=int, default=16, help="cycles between tool changes (0: never; 16)")
    p.add_argument("--cycle-minutes", type=float, default=20.0, help="minutes per cycle (20)")
    p.add_argument(
        "--sparse",
        type=int,
        default=0,
        help="registers the operator changes per correction, the largest (0: all, least-norm shares; "
        "then every register moves in proportion and a wrong relation's register cannot be named)",
    )
    p.add_argument("--per-cycle", action="store_true", help="one measurement file per cycle")
    p.add_argument(
        "--start", default=SIMULATE_START, help=f"time of the first cycle, ISO 8601 (default {SIMULATE_START})"
    )
    p.add_argument("--seed", type=int, default=None, help="seed (reproducible series)")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.usecases.simulate import parse_effect, simulate_series, write_series

    effects = [parse_effect(e) for e in args.effect]
    params = {
        "n_cycles": args.cycles,
        "noise": args.noise,
        "setup_error": args.setup_error,
        "correct_every": args.correct_every,
        "dead_time": args.dead_time,
        "tool_change_every": args.tool_change_every,
        "cycle_minutes": args.cycle_minutes,
        "sparse": args.sparse,
        "seed": args.seed,
    }
    model, layout, sim = simulate_series(args.model, effects, **params)
    files = write_series(
        model,
        layout,
        sim,
        args.out,
        per_cycle=args.per_cycle,
        start=args.start,
        settings={**params, "effects": args.effect},
    )
    if args.json:
        json.dump({"files": list(files), "hidden_effects": sim.truth.get("effects", [])}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        hidden = ", ".join(f"{e['kind']} ({e['target']}) {e['magnitude']:g}" for e in sim.truth.get("effects", []))
        sys.stdout.write(f"{sim.series.n_cycles} cycles, {len(sim.log_time)} log rows, hidden: {hidden or 'none'}\n")
        sys.stdout.write("".join(f"wrote {f}\n" for f in files))
    return OK
