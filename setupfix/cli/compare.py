"""``setupfix compare``: every optimiser, N seeded trials each, beside the exact grid optimum."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.cli.common import (
    add_machine_options,
    add_report_options,
    add_time_limit_option,
    cycles_of,
    read_options,
    store_ref,
    whole_number,
)


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compare",
        help="compare the metaheuristics with the exact optimum on one report",
        description="Run CRIPSO, PSO, GA, COA and cuckoo search N seeded times each on one "
        "measured part and tabulate best / median / worst f1, f2 and f beside the "
        "exact grid optimum (Stryczek 2014, Figs. 12-17).",
    )
    p.add_argument("report", metavar="REPORT", help="CMM report in any supported format")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument(
        "--trials", type=whole_number(1, 10_000), default=12, metavar="N", help="seeded trials per method (default 12)"
    )
    add_time_limit_option(p)
    p.add_argument("--seed", type=int, default=0, metavar="S", help="root of the trial seeds (default 0)")
    p.add_argument("--part", default=None, metavar="ID", help="part / cycle of the report (default: the first)")
    p.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/cli-json.md)")
    p.add_argument(
        "--plot", default=None, metavar="FILE", help="draw convergence and spread figures to FILE (.png or .svg)"
    )
    p.add_argument(
        "--store",
        metavar="DB",
        default=None,
        help="history store (a file, or a postgresql:// URL), as correct reads it: the EWMA smoothing and "
        "the recent measurements that stand in for dimensions the report lacks (nothing is recorded)",
    )
    add_machine_options(p)
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="with --store: the stored reports marked rejected, failed or draft are read too, as correct reads them",
    )
    p.add_argument(
        "--current",
        metavar="FILE",
        default=None,
        help="the controller's current offsets (as correct reads them: the cumulative limit of wear registers)",
    )
    add_report_options(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.outputs.plots import figure_format
    from setupfix.outputs.writers import check_target
    from setupfix.usecases.compare import CompareRequest, compare_report, plot_comparison
    from setupfix.usecases.contract import note_lines
    from setupfix.usecases.correct import load_request
    from setupfix.usecases.requests import SolveOptions
    from setupfix.views.present import format_comparison

    if args.plot:
        figure_format(args.plot)  # refuse an unknown suffix or target before the trials, not after
        check_target(args.plot)
    correct = load_request(  # correct's request, read as correct reads it: the same problem is compared
        args.model,
        read=read_options(args),
        cycles=cycles_of(args),
        solve=SolveOptions("exact", None, args.time_limit, "paper"),
        current=args.current,
        store=store_ref(args, args.store),
        include_excluded=args.include_excluded,
    )
    request = CompareRequest(correct, trials=args.trials, seed=args.seed)
    comparison = compare_report(request, args.report)
    if args.plot:
        plot_comparison(comparison, args.plot)
    for warning in note_lines(comparison.notes):  # the reader's and the matching's notes: a skipped row is never silent
        print(f"warning: {warning}", file=sys.stderr)
    if args.json:
        json.dump(comparison.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_comparison(comparison) + "\n")
        if args.plot:
            sys.stdout.write(f"figures written to {args.plot}\n")
    return 0
