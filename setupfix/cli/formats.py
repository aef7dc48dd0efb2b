"""``setupfix formats``: the report formats setupfix reads."""

from __future__ import annotations

import argparse
import json
import sys

from setupfix.cli.exit_codes import OK


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "formats",
        help="list the supported report formats",
        description="List the report formats in the order their content is sniffed.",
    )
    p.add_argument("--json", action="store_true", help="machine-readable list")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.usecases.parse import list_formats

    rows = list_formats()
    if args.json:
        json.dump(rows, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return OK
    width = max(len(str(r["name"])) for r in rows) + 2
    ext_width = max(len(", ".join(r["extensions"])) for r in rows) + 2  # type: ignore[arg-type]  # a list of str
    print(f"{'format':<{width}}{'extensions':<{ext_width}}description")
    for r in rows:
        extensions = ", ".join(r["extensions"])  # type: ignore[arg-type]  # a list of str
        print(f"{r['name']:<{width}}{extensions:<{ext_width}}{r['description']}")
    return OK
