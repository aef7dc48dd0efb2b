"""``setupfix correct``: corrections for one report."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from setupfix.cli.choices import CONTROLLERS, OPTIMIZERS
from setupfix.cli.common import (
    add_machine_options,
    add_objective_option,
    add_program_number_option,
    add_report_options,
    add_thermal_options,
    add_time_limit_option,
    check_program_number,
    cycles_of,
    read_options,
    store_ref,
)
from setupfix.cli.exit_codes import NOT_SOLVED, OK, REJECTED
from setupfix.cli.machine import add_link_options, link_current

if TYPE_CHECKING:
    from setupfix.usecases.export import Exported
    from setupfix.usecases.requests import CorrectRequest


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "correct",
        help="setup corrections (WKS and tool offsets) for one CMM report",
        description="Compute the WKS and tool-length corrections that maximise the unilateral "
        "error budget of the measured part(s) (Stryczek 2014), under the model's "
        "safety rules. Exit status 5 when a recommendation is rejected, 6 when a "
        "solve was stopped by its time limit with nothing proven to recommend "
        "(nothing is exported then).",
    )
    p.add_argument("report", metavar="REPORT", help="CMM report in any supported format")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument(
        "--optimizer",
        default="exact",
        choices=sorted(OPTIMIZERS),
        help="exact (default: proved grid optimum) or a metaheuristic",
    )
    p.add_argument("--seed", type=int, default=None, help="seed of a metaheuristic (reproducible runs)")
    add_time_limit_option(p)
    add_objective_option(p)
    p.add_argument("--part", default=None, metavar="ID", help="correct only this part / cycle of the report")
    p.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/cli-json.md)")
    p.add_argument(
        "--store",
        metavar="DB",
        default=None,
        help="history store (a file, or a postgresql:// URL): earlier reports and the corrections log "
        "for the EWMA smoothing (model [safety] ewma < 1) and for the recent measurements that "
        "stand in for dimensions the report lacks; the recommendation is recorded in it (the "
        "audit trail: machine, operator, report hash, verdict, deltas, where it was exported)",
    )
    add_machine_options(p)
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="with --store: the stored reports marked rejected, failed or draft enter the smoothing and the "
        "stand-ins too (left out by default, and counted)",
    )
    p.add_argument(
        "--html",
        metavar="OUT",
        default=None,
        help="also write one self-contained HTML page of the correction (verdict, tolerance zones with "
        "measured and predicted positions, registers, rules; with --store the control charts of "
        "the stored series); prints on A4",
    )
    add_offsets_options(p)
    add_link_options(p)
    add_report_options(p)
    add_thermal_options(p)
    p.set_defaults(run=run)


def add_offsets_options(p: argparse.ArgumentParser) -> None:
    """--offsets/--out target, --controller and --current (shared with batch)."""
    p.add_argument("--offsets", metavar="FILE", default=None, help="write the offsets here ('-': stdout)")
    p.add_argument(
        "--controller", default="csv", choices=sorted(CONTROLLERS), help="syntax of the offsets file (default csv)"
    )
    p.add_argument(
        "--current",
        metavar="FILE",
        default=None,
        help="the controller's current offsets (CSV register,value; register,axis,value in a "
        "multi-axis model): write absolute new values",
    )
    add_program_number_option(p)


def correct_request(args: argparse.Namespace) -> CorrectRequest:
    """The :class:`~setupfix.usecases.requests.CorrectRequest` of ``correct``'s arguments (every input loaded once)."""
    from setupfix.model import load_model
    from setupfix.usecases.correct import load_request
    from setupfix.usecases.requests import SolveOptions

    model = load_model(args.model)
    solve = SolveOptions(args.optimizer, args.seed, args.time_limit, args.objective)  # bad options before the link
    return load_request(
        model,
        read=read_options(args),
        cycles=cycles_of(args),
        solve=solve,
        current=link_current(args, model) or args.current,  # --link: read from the control
        store=store_ref(args, args.store),
        thermal=args.thermal,
        temperatures=args.temperatures,
        at=args.at,
        thermal_dead_band=args.thermal_dead_band,
        include_excluded=args.include_excluded,
    )


def run(args: argparse.Namespace) -> int:
    from setupfix.outputs.writers import check_target
    from setupfix.usecases.contract import note_lines, outcome_json
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.export import export
    from setupfix.usecases.history import record_correction
    from setupfix.views.html import write_correction_page
    from setupfix.views.present import format_correction, verdict_line

    if args.offsets:
        check_target(args.offsets)
        check_program_number(args)
    if args.html:
        check_target(args.html)
    request = correct_request(args)
    outcome = correct_report(request, args.report)
    cycles = outcome.cycles
    rejected, unsolved = bool(outcome.rejected), bool(outcome.unsolved)

    def write() -> Exported | None:
        if not args.offsets or rejected or unsolved:
            return None
        return export(
            cycles,
            args.offsets,
            controller=args.controller,
            current=request.current,
            program_number=args.program_number,
        )

    if args.store:  # the recommendation goes into the audit trail; the offsets are written only with it
        record_correction(
            store_ref(args, args.store), request.model, cycles, report=args.report, seed=args.seed, write=write
        )
    else:
        write()
    if args.html:
        write_correction_page(outcome, args.html, store=store_ref(args, args.store))
    for c in outcome.rejected:
        print(f"error: {c.part.report}: part {c.part.part or '—'}: {c.recommendation.alarm}", file=sys.stderr)
    for c in cycles:
        if c.verdict != "reject" and c.recommendation.alarm:  # a setup error, held: nothing changed, check it
            print(f"warning: {c.part.report}: part {c.part.part or '—'}: {c.recommendation.alarm}", file=sys.stderr)
    for c in outcome.unsolved:
        print(
            f"error: {c.part.report}: part {c.part.part or '—'}: NOT SOLVED: {verdict_line(c)}"
            + ("; nothing exported" if args.offsets else ""),
            file=sys.stderr,
        )
    status = REJECTED if rejected else NOT_SOLVED if unsolved else OK
    if args.json or args.offsets == "-":  # the table below prints them; here they must not be lost
        for c in cycles:
            for line in note_lines(c.notes):
                print(f"warning: {line}", file=sys.stderr)
    if args.offsets == "-":
        return status
    if args.json:
        plan = outcome_json(cycles)
        if request.current is not None and request.current.snapshot is not None:  # --link: the values it was made with
            plan["link"] = request.current.snapshot.to_json()
        json.dump(plan, sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write("\n\n".join(format_correction(c) for c in cycles) + "\n")
    return status
