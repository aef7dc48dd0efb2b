"""``setupfix machine read|write``: the control's offsets over a machine link (``shared/spec/machine-link.md``).

Also the ``--link``/``--insecure`` options of ``correct`` and ``batch`` (:func:`add_link_options`,
:func:`link_current`): the current offsets read from the control instead of a ``--current`` file.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from setupfix.cli.common import add_machine_options, shown
from setupfix.cli.exit_codes import OK
from setupfix.cli.machine.options import INSECURE_HELP, add_link_options, link_current

__all__ = ["add_parser", "add_link_options", "link_current", "format_read", "format_write"]

if TYPE_CHECKING:
    from setupfix.usecases.machine import ControlRead, WriteOutcome


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "machine",
        help="read the control's offsets, or write a correction with read-back (machine link)",
        description="Talk to a control through a link file (OPC UA, LinuxCNC): read its offsets, or "
        "write a plan's corrections with the guarded sequence (dry run by default). Exit status: 0 written "
        "and read back, or a dry run; 1 bad input; 6 refused before any write; 7 written but not confirmed "
        "(rolled back, or CHECK THE CONTROL); 8 the control could not be reached.",
    )
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    r = actions.add_parser("read", help="read the control's offsets", description="Read every mapped component.")
    r.add_argument("--link", required=True, metavar="LINK", help="the link file (TOML)")
    r.add_argument("--model", default=None, metavar="MODEL", help="read only the model's register components")
    r.add_argument("--json", action="store_true", help="machine-readable output")
    r.add_argument(
        "--out", default=None, metavar="CSV", help="write the values as a --current CSV (needs --model: its unit)"
    )
    r.add_argument("--insecure", action="store_true", help=INSECURE_HELP)
    r.set_defaults(run=run_read)
    w = actions.add_parser(
        "write",
        help="write a plan's corrections to the control (dry run unless --apply)",
        description="Without --apply: read the control and show per component the current value, the change "
        "and the new value; nothing is written. With --apply: re-read (refused if the table changed since "
        "the plan), check the interlock and the limits, write at the control's increment, read back, roll "
        "back on any mismatch; every attempt is recorded with --db.",
    )
    w.add_argument("report", metavar="REPORT", nargs="?", default=None, help="a report to correct now (or --plan)")
    w.add_argument("--link", required=True, metavar="LINK", help="the link file (TOML)")
    w.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    w.add_argument("--plan", default=None, metavar="PLAN", help="a plan: correct --link --json output of one part")
    w.add_argument("--part", default=None, metavar="ID", help="with REPORT: the part / cycle to correct")
    w.add_argument("--apply", action="store_true", help="write (default: a dry run)")
    w.add_argument("--db", default=None, metavar="STORE", help="history store: every attempt is recorded in its audit")
    w.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/machine-link.md)")
    w.add_argument("--insecure", action="store_true", help=INSECURE_HELP)
    add_machine_options(w)
    w.set_defaults(run=run_write)


def run_read(args: argparse.Namespace) -> int:
    from setupfix.core.atomic import check_target
    from setupfix.core.errors import SetupfixError
    from setupfix.links import open_link
    from setupfix.model import load_model
    from setupfix.usecases.machine import read_control, write_current_csv

    if args.out is not None and args.model is None:
        raise SetupfixError("--out needs --model: the --current CSV holds the model's registers in its unit")
    if args.out is not None:
        check_target(args.out)
    model = load_model(args.model) if args.model is not None else None
    with open_link(args.link, insecure=args.insecure) as link:
        read = read_control(link, model)
    if args.out is not None and model is not None:
        write_current_csv(read, model, args.out)
    if args.json:
        json.dump(read.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    elif args.out != "-":
        sys.stdout.write(format_read(read) + "\n")
    return OK


def format_read(read: ControlRead) -> str:
    s = read.snapshot
    ids = dict(read.ids)
    lines = [f"{shown(s.link)}: {len(s.values)} value(s), {s.unit}, increment {s.increment:g}"]
    for c, v in s.values:
        unit = "deg" if c.rotation else s.unit
        lines.append(f"  {c!s:<12} {v:>14.6f} {unit}" + (f"  ({ids[c]})" if c in ids else ""))
    return "\n".join(lines)


def run_write(args: argparse.Namespace) -> int:
    import contextlib

    from setupfix.core.errors import SetupfixError
    from setupfix.inputs.stores import StoreRef
    from setupfix.links import open_link
    from setupfix.model import load_model
    from setupfix.usecases.machine import load_plan, report_plan, write_to_control

    if (args.plan is None) == (args.report is None):
        raise SetupfixError("give a plan (--plan PLAN.json) or a report to correct, not both and not neither")
    model = load_model(args.model)
    plan = load_plan(args.plan, model) if args.plan is not None else None
    with open_link(args.link, insecure=args.insecure) as link:
        ref = StoreRef(args.db, args.machine or link.machine, args.operator).for_model(model) if args.db else None
        if plan is None:
            plan = report_plan(model, args.report, link, part=args.part, apply=args.apply, store=ref)
        with ref.open(existing=False) if ref is not None else contextlib.nullcontext() as store:
            result = write_to_control(model, plan, link, apply=args.apply, store=store)
    return _show(result, args.json)


def _show(result: WriteOutcome, as_json: bool) -> int:
    if as_json:
        json.dump(result.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_write(result) + "\n")
    if result.exit_status != OK:
        print(f"error: {shown(result.message)}", file=sys.stderr)
    return result.exit_status


def format_write(result: WriteOutcome) -> str:
    def n(v: float | None) -> str:
        return "" if v is None else f"{v:.6f}"

    head = f"{shown(result.link)}: {result.outcome.replace('_', ' ')}" + (
        f" (machine {shown(result.machine)})" if result.machine else ""
    )
    lines = [head, f"  {'component':<12} {'before':>14} {'change':>12} {'new':>14} {'read back':>14}  unit"]
    for r in result.rows:
        unit = "deg" if r.component.rotation else result.unit
        lines.append(
            f"  {r.component!s:<12} {n(r.before):>14} {n(r.change):>12} {n(r.new):>14} {n(r.read_back):>14}  {unit}"
        )
    lines.append(f"  {shown(result.message)}")
    return "\n".join(lines)
