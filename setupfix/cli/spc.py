"""``setupfix spc``: capability, control charts and Nelson rules of the series in a history store."""

from __future__ import annotations

import argparse
from pathlib import Path

from setupfix.cli.common import emit_outcome, whole_number
from setupfix.core.errors import ParameterError, SourceLocation, StoreError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "spc",
        help="capability (Cp/Cpk/Pp/Ppk), control charts and Nelson rules from the store",
        description="Per stored characteristic: n, mean, σ within (mean moving range / 1.128), "
        "σ overall, Cp, Cpk with its 95 % interval, Pp, Ppk and the parts out of "
        "tolerance; individuals and moving-range limits from the first --baseline "
        "parts; Nelson rules 1-4 with the parts each violation covers; the "
        "capability before and after each --split time (default: each correction "
        "in the store's log).  Values are deviations from nominal.",
    )
    p.add_argument(
        "--db",
        metavar="STORE",
        default=None,
        help="history store: a file (SQLite) or a postgresql:// URL (default: $SETUPFIX_DB, else setupfix.db here)",
    )
    p.add_argument(
        "--machine", metavar="NAME", default=None, help="the machine whose series are read (default: 'default')"
    )
    p.add_argument("--since", metavar="TIME", default=None, help="only parts made at or after TIME (ISO 8601)")
    p.add_argument("--until", metavar="TIME", default=None, help="only parts made at or before TIME (ISO 8601)")
    p.add_argument(
        "--dimension",
        metavar="NAME",
        nargs="+",
        action="extend",
        default=[],
        help="characteristics to report (default: every one stored); repeatable",
    )
    p.add_argument(
        "--baseline",
        metavar="N",
        type=whole_number(2, 10**9),
        default=20,
        help="parts the control limits are computed from (the first N; default 20)",
    )
    p.add_argument(
        "--split",
        metavar="TIME",
        action="append",
        default=[],
        help="compare the capability before and after TIME; repeatable (default: each correction in the store)",
    )
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="take in the reports the store keeps marked rejected, failed or draft (left out by default, and counted)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--html",
        metavar="OUT",
        default=None,
        help="also write one self-contained HTML page (charts inline, prints on A4); '-': the page alone "
        "to standard output",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.outputs.writers import check_target
    from setupfix.store import is_server, open_store
    from setupfix.usecases.history import store_location
    from setupfix.usecases.spc_report import SpcRequest, format_spc, spc_json, spc_report
    from setupfix.views.html import spc_page

    location = store_location(args.db)
    if args.html == "-" and args.json:
        raise ParameterError(
            "spc: --html - and --json would both write to standard output", hint="give --html a file name"
        )
    if args.html:
        check_target(args.html)
    if not is_server(location) and not Path(location).is_file():
        raise StoreError(
            "no history store here",
            location=SourceLocation(location),
            hint="create it with 'setupfix history import', or give --db",
        )
    request = SpcRequest(
        since=args.since,
        until=args.until,
        dimensions=tuple(args.dimension),
        baseline=args.baseline,
        splits=tuple(args.split),
        include_excluded=args.include_excluded,
    )
    with open_store(location, machine=args.machine) as store:
        outcome = spc_report(store, request)
    return emit_outcome(
        args.html, lambda: spc_page(outcome), args.json, lambda: spc_json(outcome), lambda: format_spc(outcome)
    )
