"""Options shared by the sub-commands that read reports."""

from __future__ import annotations

import argparse
from typing import Any

from setupfix.errors import SetupfixError


def add_report_options(p: argparse.ArgumentParser) -> None:
    """Reader options: format, unit, encoding, column mapping, stations."""
    g = p.add_argument_group("report reading")
    g.add_argument("--format", default=None, metavar="NAME", help="report format (default: sniffed; see 'formats')")
    g.add_argument("--unit", default=None, choices=("mm", "inch"), help="unit of values the report does not label")
    g.add_argument("--encoding", default=None, metavar="ENC", help="text encoding (default: sniffed)")
    g.add_argument("--columns", default=None, metavar="MAP",
                   help="column mapping for shop tables, e.g. actual=Meas,nominal=Nom")
    g.add_argument("--stations", default=None, metavar="LIST",
                   help="fixture stations of the report's parts, in order (P1,P2,…) or as part=station pairs")


def report_options(args: argparse.Namespace) -> dict[str, Any]:
    return {"format": args.format, "unit": args.unit, "encoding": args.encoding, "columns": args.columns}


def parse_stations(text: str | None) -> list[str] | dict[str, str] | None:
    """``P1,P2`` → list; ``A7=P1,A8=P2`` → mapping part → station."""
    if not text:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    if all("=" in t for t in items):
        return dict(tuple(s.strip() for s in t.split("=", 1)) for t in items)  # type: ignore[misc]
    if any("=" in t for t in items):
        raise SetupfixError(f"--stations {text!r}: give either a list (P1,P2) or pairs (part=station), not both")
    return items
