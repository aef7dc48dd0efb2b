"""``setupfix history import|show|export``: the history store (reports, corrections, temperatures)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from typing import Any

from setupfix.cli._choices import HISTORY_EXPORTS
from setupfix.cli._common import add_lenient_option
from setupfix.errors import SourceLocation, StoreError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("history", help="the history store: import reports and logs, show, export",
                       description="Keep every report (by content hash: importing one twice changes nothing), "
                                   "the corrections log, the temperature log and every recommendation in one "
                                   "SQLite file.")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--db", default=None, metavar="PATH",
                        help="store file (default: setupfix.db beside --model, else in the current folder)")
    common.add_argument("--model", default=None, metavar="MODEL",
                        help="process model TOML: locates the store; on import, the corrections log is checked "
                             "against it")
    imp = actions.add_parser("import", parents=[common], help="store reports, a corrections log, a temperature log",
                             description="Read every file first, then store all of them in one transaction.")
    imp.add_argument("reports", nargs="*", metavar="REPORT",
                     help="CMM reports in any supported format; a folder stands for the reports in it and its "
                          "sub-folders (hidden, partial files and models left out; a link to a folder or an "
                          "unreadable one named in a warning) and its corrections.csv / temperatures.csv are "
                          "imported unless --corrections / --temperatures are given")
    imp.add_argument("--corrections", action="append", default=[], metavar="CSV",
                     help="corrections log (timestamp,register,delta[,event]; header in any case); repeatable; "
                          "with --model every register is checked against the model, as diagnose does")
    imp.add_argument("--temperatures", action="append", default=[], metavar="CSV",
                     help="temperature log (timestamp, one column per channel); repeatable")
    imp.add_argument("--format", default=None, metavar="NAME", help="report format (default: sniffed)")
    imp.add_argument("--unit", default=None, choices=("mm", "inch"), help="unit of values the report does not label")
    imp.add_argument("--encoding", default=None, metavar="ENC", help="text encoding (default: sniffed)")
    add_lenient_option(imp)
    show = actions.add_parser("show", parents=[common], help="summary of the stored reports and logs")
    show.add_argument("--json", action="store_true", help="machine-readable output")
    exp = actions.add_parser("export", parents=[common], help="write a stored table as its canonical CSV")
    exp.add_argument("table", choices=HISTORY_EXPORTS, help="which table")
    exp.add_argument("--out", required=True, metavar="CSV", help="output CSV ('-': stdout)")
    for action in (imp, show, exp):
        action.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.model import load_model
    from setupfix.pipeline.history import (ImportRequest, default_db_path, export_history, history_summary,
                                           import_history)
    from setupfix.pipeline.requests import ReadOptions
    from setupfix.pipeline.writers import check_target
    from setupfix.store import open_store

    path = default_db_path(args.db, args.model)
    if args.action == "export":
        check_target(args.out)
    if args.action != "import" and not path.is_file():
        raise StoreError("no history store here", location=SourceLocation(str(path)),
                         hint="create it with 'setupfix history import', or give --db")
    model = load_model(args.model) if args.action == "import" and args.model else None  # before the store opens
    with open_store(path) as store:
        if args.action == "import":
            read = ReadOptions(format=args.format, unit=args.unit, encoding=args.encoding, lenient=args.lenient)
            s = import_history(store, ImportRequest(tuple(args.reports), tuple(args.corrections),
                                                    tuple(args.temperatures), read, model))
            for note in s.notes:
                print(f"warning: {note}", file=sys.stderr)
            print(f"{path}: {len(s.new_reports)} new report(s), {len(s.known_reports)} already stored, "
                  f"{s.corrections} new log row(s), {s.temperatures} new temperature value(s)")
        elif args.action == "show":
            summary = history_summary(store)
            if args.json:
                json.dump(summary, sys.stdout, indent=2)
                sys.stdout.write("\n")
            else:
                sys.stdout.write(_format(summary) + "\n")
        else:
            n = export_history(store, args.table, args.out)
            if args.out != "-":
                print(f"{n} {args.table} row(s) → {args.out}", file=sys.stderr)
    return 0


def _format(s: Mapping[str, Any]) -> str:
    """The ``history show`` summary (the JSON object ``--json`` prints, values as JSON gives them) as text."""
    lines = [f"{s['store']}: {len(s['reports'])} report(s)"]
    if s["reports"]:
        lines.append(f"{'report':<32}{'format':<10}{'rows':>6}{'parts':>6}  {'first':<20}{'last':<20}sha256")
        for r in s["reports"]:
            lines.append(f"{r['report'][:31]:<32}{r['format']:<10}{r['rows']:>6}{r['parts']:>6}  "
                         f"{r['first'][:19]:<20}{r['last'][:19]:<20}{r['sha256']}")
    lines.append(f"corrections: {s['corrections']}, tool changes: {s['tool_changes']}"
                 + (f" (registers {', '.join(s['registers'])})" if s["registers"] else ""))
    lines.append(f"temperature samples: {s['temperature_samples']}"
                 + (f" ({', '.join(s['temperature_channels'])})" if s["temperature_channels"] else ""))
    lines.append(f"recommendations: {s['recommendations']}")
    return "\n".join(lines)
