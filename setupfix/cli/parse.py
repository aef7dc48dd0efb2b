"""``setupfix parse``: reports in any supported format → the canonical measurement CSV."""

from __future__ import annotations

import argparse
import sys

from setupfix.cli.common import read_options
from setupfix.cli.exit_codes import ERROR, OK, PARTIAL
from setupfix.core.errors import SetupfixError


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "parse",
        help="read CMM reports into the canonical measurement CSV",
        description="Read CMM reports (QIF, DMIS, CALYPSO, shop tables, …) and write one canonical "
        "measurement table: lengths in mm, deviation = actual - nominal, limits as "
        "signed deviations. A bad file is named on stderr; the others are still written.",
    )
    p.add_argument(
        "files",
        nargs="+",
        metavar="FILE",
        help="report files; a folder stands for the reports in it and its sub-folders (hidden, "
        "partial and log files and models left out; a link to a folder or an unreadable one "
        "named in a warning), '-' for standard input",
    )
    p.add_argument(
        "-o",
        "--out",
        required=True,
        metavar="CSV",
        help="output CSV ('-': stdout); written atomically, as model init -o",
    )
    p.add_argument("--format", default=None, metavar="NAME", help="report format (default: sniffed; see 'formats')")
    p.add_argument("--unit", default=None, choices=("mm", "inch"), help="unit of values the report does not label")
    p.add_argument(
        "--encoding",
        default=None,
        metavar="ENC",
        type=_encoding,
        help="text encoding, e.g. utf-8, cp1252, cp949 (default: sniffed)",
    )
    p.add_argument(
        "--columns",
        default=None,
        metavar="MAP",
        help="column mapping for shop tables (actual=Meas,nominal=Nom,...) or a mapping file",
    )
    p.add_argument(
        "--lenient",
        action="store_true",
        help="skip a row that contradicts itself (named in a warning) instead of refusing its report; "
        "readers that cannot tell such rows apart refuse the option",
    )
    p.set_defaults(run=run)


def _encoding(text: str) -> str:
    """argparse type: a usable character set (``--encoding punycode`` is refused with the reason)."""
    from parsers.source import check_encoding  # here: importing the parsers loads pandas

    try:
        return check_encoding(text)
    except SetupfixError as exc:
        raise argparse.ArgumentTypeError(exc.message) from None


def run(args: argparse.Namespace) -> int:
    from setupfix.outputs.writers import check_target, write_canonical_csv
    from setupfix.usecases.parse import parse_reports

    check_target(args.out)
    outcome = parse_reports(args.files, read_options(args))
    for report in outcome.reports:
        for line in report.warnings:
            print(f"warning: {line}", file=sys.stderr)
    for note in outcome.problems:
        print(f"warning: {note}", file=sys.stderr)
    for note in outcome.skipped:
        print(f"note: {note}", file=sys.stderr)
    for failure in outcome.failures:
        print(f"error: {failure}", file=sys.stderr)
    if not outcome.reports:
        return ERROR
    table = outcome.table
    write_canonical_csv(table, args.out)
    if args.out != "-":
        print(
            f"{len(table)} rows from {len(outcome.reports)} of {outcome.inputs} file(s) → {args.out}", file=sys.stderr
        )
    return PARTIAL if outcome.failures else OK
