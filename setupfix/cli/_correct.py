"""``setupfix correct``: corrections for one report."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.cli._choices import CONTROLLERS, OPTIMIZERS
from setupfix.cli._common import add_report_options, add_thermal_options, cycle_options, report_options
from setupfix.cli.exit_codes import OK, REJECTED
from setupfix.errors import ParameterError, SetupfixError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("correct", help="setup corrections (WKS and tool offsets) for one CMM report",
                       description="Compute the WKS and tool-length corrections that maximise the unilateral "
                                   "error budget of the measured part(s) (Stryczek 2014), under the model's "
                                   "safety rules. Exit status 5 when a recommendation is rejected.")
    p.add_argument("report", metavar="REPORT", help="CMM report in any supported format")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument("--optimizer", default="exact", choices=sorted(OPTIMIZERS),
                   help="exact (default: proved grid optimum) or a metaheuristic")
    p.add_argument("--seed", type=int, default=None, help="seed of a metaheuristic (reproducible runs)")
    p.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                   help="wall time of the exact optimiser's whole solve per part (default 2)")
    p.add_argument("--part", default=None, metavar="ID", help="correct only this part / cycle of the report")
    p.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/cli-json.md)")
    p.add_argument("--store", metavar="DB", default=None,
                   help="history store: earlier reports and the corrections log for the EWMA smoothing "
                        "(model [safety] ewma < 1)")
    add_offsets_options(p)
    add_report_options(p)
    add_thermal_options(p)
    p.set_defaults(run=run)


def add_offsets_options(p: argparse.ArgumentParser) -> None:
    """--offsets/--out target, --controller and --current (shared with batch)."""
    p.add_argument("--offsets", metavar="FILE", default=None, help="write the offsets here ('-': stdout)")
    p.add_argument("--controller", default="csv", choices=sorted(CONTROLLERS),
                   help="syntax of the offsets file (default csv)")
    p.add_argument("--current", metavar="FILE", default=None,
                   help="the controller's current offsets (CSV register,value): write absolute new values")


def exact_params(time_limit: float | None, optimizer: str = "exact") -> dict[str, float]:
    """``--time-limit`` as the exact optimiser's parameter (checked by its declared constraints)."""
    if time_limit is None:
        return {}
    if optimizer != "exact":
        raise ParameterError(f"--time-limit applies to the exact optimizer, not {optimizer!r}")
    return {"time_limit": time_limit}


def run(args: argparse.Namespace) -> int:
    from setupfix.model import load_model
    from setupfix.pipeline.controllers import read_current
    from setupfix.pipeline.correct import correct_report, open_history, write_correction_offsets
    from setupfix.pipeline.present import format_correction
    from setupfix.pipeline.writers import check_target

    if args.offsets:
        check_target(args.offsets)
    store = open_history(args.store) if args.store else None
    model = load_model(args.model)
    current = read_current(args.current, model) if args.current else None
    params = exact_params(args.time_limit, args.optimizer)
    results = correct_report(model, args.report, optimizer=args.optimizer, seed=args.seed, part=args.part,
                             store=store, current=current, params=params, **cycle_options(args),
                             **report_options(args))
    if args.thermal or args.temperatures:  # thermal feed-forward step (setupfix.pipeline.feedforward)
        from setupfix.pipeline.feedforward import apply_feed_forward

        if not (args.thermal and args.temperatures):
            raise SetupfixError("--thermal and --temperatures go together")
        apply_feed_forward(results, args.thermal, args.temperatures, at=args.at, dead_band=args.thermal_dead_band)
    rejected = any(r.verdict == "reject" for r in results)
    if args.offsets and not rejected:
        write_correction_offsets(results, args.offsets, controller=args.controller, current=current)
    for r in results:
        if r.verdict == "reject":
            print(f"error: {r.part.report}: part {r.part.part or '—'}: {r.recommendation.alarm}", file=sys.stderr)
    if args.json or args.offsets == "-":  # the table below prints them; here they must not be lost
        for r in results:
            for warning in r.warnings:
                print(f"warning: {warning}", file=sys.stderr)
    if args.offsets == "-":
        return REJECTED if rejected else OK
    if args.json:
        objs = [r.to_json() for r in results]
        json.dump(objs[0] if len(objs) == 1 else {"parts": objs}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write("\n\n".join(format_correction(r) + (f"\n{r.thermal.line()}" if r.thermal else "")
                                       for r in results) + "\n")
    return REJECTED if rejected else OK
