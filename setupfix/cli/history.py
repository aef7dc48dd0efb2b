"""``setupfix history import|show|export|migrate``: the history store (reports, corrections, temperatures, audit)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from setupfix.cli.choices import HISTORY_EXPORTS
from setupfix.cli.common import add_lenient_option
from setupfix.core.errors import SourceLocation, StoreError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "history",
        help="the history store: import reports and logs, show, export, migrate",
        description="Keep every report (by content hash: importing one twice changes nothing), "
        "the corrections log, the temperature log and every recommendation with its "
        "audit trail, per machine, in one SQLite file or one PostgreSQL database.",
    )
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--db",
        default=None,
        metavar="PATH|URL",
        help="store: a file (SQLite) or postgresql://user:password@host:port/database (default: "
        "$SETUPFIX_DB, else setupfix.db beside --model, else in the current folder)",
    )
    common.add_argument(
        "--machine",
        default=None,
        metavar="NAME",
        help="the machine whose rows are written and read (default: 'default'); show and "
        "export recommendations without it cover every machine",
    )
    common.add_argument(
        "--operator", default=None, metavar="NAME", help="who stores recommendations (default: the login name)"
    )
    common.add_argument(
        "--model",
        default=None,
        metavar="MODEL",
        help="process model TOML: locates the store; on import, the corrections log is checked against it",
    )
    imp = actions.add_parser(
        "import",
        parents=[common],
        help="store reports, a corrections log, a temperature log",
        description="Read every file first, then store all of them in one transaction.",
    )
    imp.add_argument(
        "reports",
        nargs="*",
        metavar="REPORT",
        help="CMM reports in any supported format; a folder stands for the reports in it and its "
        "sub-folders (hidden, partial files and models left out; a link to a folder or an "
        "unreadable one named in a warning) and its corrections.csv / temperatures.csv are "
        "imported unless --corrections / --temperatures are given",
    )
    imp.add_argument(
        "--corrections",
        action="append",
        default=[],
        metavar="CSV",
        help="corrections log (timestamp,register,delta[,event]; header in any case); repeatable; "
        "with --model every register is checked against the model, as diagnose does",
    )
    imp.add_argument(
        "--temperatures",
        action="append",
        default=[],
        metavar="CSV",
        help="temperature log (timestamp, one column per channel); repeatable",
    )
    imp.add_argument("--format", default=None, metavar="NAME", help="report format (default: sniffed)")
    imp.add_argument("--unit", default=None, choices=("mm", "inch"), help="unit of values the report does not label")
    imp.add_argument("--encoding", default=None, metavar="ENC", help="text encoding (default: sniffed)")
    add_lenient_option(imp)
    show = actions.add_parser("show", parents=[common], help="summary per machine; with --machine, its reports")
    show.add_argument("--json", action="store_true", help="machine-readable output")
    exp = actions.add_parser(
        "export",
        parents=[common],
        help="write a stored table as its canonical CSV",
        description="measurements, corrections, temperatures: the machine's rows; "
        "recommendations: the audit trail, one row per register component "
        "(every machine unless --machine is given)",
    )
    exp.add_argument(
        "table",
        choices=HISTORY_EXPORTS,
        help="which table (recommendations: the audit trail; dfq: the measurements as an AQDEF/Q-DAS "
        "DFQ file for SPC tools)",
    )
    exp.add_argument("--out", required=True, metavar="FILE", help="output file: CSV, or DFQ for dfq ('-': stdout)")
    exp.add_argument(
        "--include-excluded",
        action="store_true",
        help="measurements and dfq: take in the reports marked excluded (a rejected, failed or draft-model "
        "report, stored for the record); by default they are left out and a warning says how many",
    )
    mig = actions.add_parser(
        "migrate",
        parents=[common],
        help="copy a SQLite store into an empty server store",
        description="Copy every row of every machine of --from into the empty store --db "
        "(one transaction; the row counts are checked).",
    )
    mig.add_argument("--from", dest="source", required=True, metavar="FILE.db", help="the SQLite store to copy")
    for action in (imp, show, exp, mig):
        action.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.model import load_model
    from setupfix.outputs.writers import check_target
    from setupfix.store import is_server, open_store
    from setupfix.usecases.history import (
        ImportRequest,
        export_history,
        history_summary,
        import_history,
        migrate_history,
        store_location,
    )
    from setupfix.usecases.requests import ReadOptions

    where = store_location(args.db, args.model)
    if args.action == "export":
        check_target(args.out)
    if args.action not in ("import", "migrate") and not is_server(where) and not Path(where).is_file():
        raise StoreError(
            "no history store here",
            location=SourceLocation(where),
            hint="create it with 'setupfix history import', or give --db",
        )
    model = load_model(args.model) if args.model and args.action == "import" else None  # before the store opens
    handle = {"machine": args.machine, "operator": args.operator}
    if args.action == "migrate":
        if not Path(args.source).is_file():
            raise StoreError("no history store here", location=SourceLocation(args.source))
        # the source is only read: opened read-only and checked whole before a row is copied
        with open_store(args.source, read_only=True) as source, open_store(where, **handle) as target:
            copied = migrate_history(source, target)
        print(f"{args.source} → {target.location}: " + ", ".join(f"{n} {t}" for t, n in copied.items()))
        return 0
    with open_store(where, **handle) as store:
        if args.action == "import":
            read = ReadOptions(format=args.format, unit=args.unit, encoding=args.encoding, lenient=args.lenient)
            s = import_history(
                store,
                ImportRequest(tuple(args.reports), tuple(args.corrections), tuple(args.temperatures), read, model),
            )
            for note in s.notes:
                print(f"warning: {note}", file=sys.stderr)
            print(
                f"{store.location} ({store.machine}): {len(s.new_reports)} new report(s), "
                f"{len(s.known_reports)} already stored, {s.corrections} new log row(s), "
                f"{s.temperatures} new temperature value(s)"
            )
        elif args.action == "show":
            summary = history_summary(store, every_machine=args.machine is None)
            if args.json:
                json.dump(summary, sys.stdout, indent=2)
                sys.stdout.write("\n")
            else:
                sys.stdout.write(_format(summary) + "\n")
        else:
            n, notes = export_history(
                store,
                args.table,
                args.out,
                every_machine=args.machine is None and args.table == "recommendations",
                include_excluded=args.include_excluded,
            )
            for note in notes:
                print(f"warning: {note}", file=sys.stderr)
            if args.out != "-":
                print(f"{n} {args.table} row(s) → {args.out}", file=sys.stderr)
    return 0


def _format(s: Mapping[str, Any]) -> str:
    """The ``history show`` summary (the JSON object ``--json`` prints, values as JSON gives them) as text."""
    machines = s["machines"]
    lines = [f"{s['store']}: {len(machines)} machine(s)"]
    if machines:
        lines.append(
            f"{'machine':<16}{'reports':>8}{'rows':>10}{'corr.':>7}{'tools':>6}{'temps':>7}{'recs':>7}"
            f"  {'first measured':<20}last measured"
        )
        for m in machines:
            lines.append(
                f"{m['machine'][:15]:<16}{m['reports']:>8}{m['rows']:>10}{m['corrections']:>7}"
                f"{m['tool_changes']:>6}{m['temperature_samples']:>7}{m['recommendations']:>7}  "
                f"{(m['first_measured'] or '')[:19]:<20}{(m['last_measured'] or '')[:19]}"
            )
    if "reports" not in s:
        return "\n".join(lines)
    lines.append(f"machine {s['machine']}: {len(s['reports'])} report(s)")
    if s["reports"]:
        lines.append(f"{'report':<32}{'format':<10}{'rows':>6}{'parts':>6}  {'first':<20}{'last':<20}sha256")
        for r in s["reports"]:
            lines.append(
                f"{r['report'][:31]:<32}{r['format']:<10}{r['rows']:>6}{r['parts']:>6}  "
                f"{r['first'][:19]:<20}{r['last'][:19]:<20}{r['sha256']}"
                + (f"  excluded: {r['excluded']}" if r.get("excluded") else "")
            )
    lines.append(
        f"corrections: {s['corrections']}, tool changes: {s['tool_changes']}"
        + (f" (registers {', '.join(s['registers'])})" if s["registers"] else "")
    )
    lines.append(
        f"temperature samples: {s['temperature_samples']}"
        + (f" ({', '.join(s['temperature_channels'])})" if s["temperature_channels"] else "")
    )
    lines.append(f"recommendations: {s['recommendations']}")
    return "\n".join(lines)
