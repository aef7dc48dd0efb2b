"""``setupfix correct``: corrections for one report."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.cli._common import add_report_options, cycle_options, report_options
from setupfix.cli._format import format_correction
from setupfix.errors import SetupfixError
from setupfix.optimize import OPTIMIZERS
from setupfix.pipeline.correct import correct_report
from setupfix.pipeline.writers import check_target, write_offsets_csv


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("correct", help="setup corrections (WKS and tool offsets) for one CMM report",
                       description="Compute the WKS and tool-length corrections that maximise the unilateral "
                                   "error budget of the measured part(s) (Stryczek 2014).")
    p.add_argument("report", metavar="REPORT", help="CMM report in any supported format")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument("--optimizer", default="exact", choices=sorted(OPTIMIZERS),
                   help="exact (default: proved grid optimum) or a metaheuristic")
    p.add_argument("--seed", type=int, default=None, help="seed of a metaheuristic (reproducible runs)")
    p.add_argument("--part", default=None, metavar="ID", help="correct only this part / cycle of the report")
    p.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/cli-json.md)")
    p.add_argument("--offsets", metavar="FILE", default=None, help="write the offsets CSV here ('-': stdout)")
    add_report_options(p)
    g = p.add_argument_group("thermal feed-forward (setupfix.pipeline.feedforward)")
    g.add_argument("--thermal", metavar="MODEL.json", default=None,
                   help="thermal model: add the drift since the measured parts were cut")
    g.add_argument("--temperatures", metavar="LOG", default=None, help="temperature log for --thermal")
    g.add_argument("--at", metavar="TIME", default=None, help="time of the correction (default: the log's last sample)")
    g.add_argument("--thermal-dead-band", type=float, default=None, metavar="D",
                   help="feed nothing forward below |D| (model unit; default one register step)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.offsets:
        check_target(args.offsets)
    results = correct_report(args.model, args.report, optimizer=args.optimizer, seed=args.seed, part=args.part,
                             **cycle_options(args), **report_options(args))
    if args.thermal or args.temperatures:  # thermal feed-forward step
        from setupfix.pipeline.feedforward import apply_feed_forward

        if not (args.thermal and args.temperatures):
            raise SetupfixError("--thermal and --temperatures go together")
        apply_feed_forward(results, args.thermal, args.temperatures, at=args.at, dead_band=args.thermal_dead_band)
    if args.offsets:
        rows = [row for r in results for row in r.offsets()]
        write_offsets_csv(rows, args.offsets, resolution=results[0].model.resolution)
    if args.offsets == "-":
        return 0
    if args.json:
        objs = [r.to_json() for r in results]
        json.dump(objs[0] if len(objs) == 1 else {"parts": objs}, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write("\n\n".join(format_correction(r) + (f"\n{r.thermal.line()}" + (" — included in the corrections above" if r.thermal.applied else "")
                                                               if r.thermal else "")
                                       for r in results) + "\n")
    return 0
