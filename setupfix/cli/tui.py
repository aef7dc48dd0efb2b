"""``setupfix tui``: the operator's terminal screen (Textual, imported only when run)."""

from __future__ import annotations

import argparse
from pathlib import Path

from setupfix.cli.choices import OPTIMIZERS
from setupfix.cli.common import (
    add_factors_option,
    add_machine_options,
    add_objective_option,
    add_report_options,
    add_thermal_options,
    cycles_of,
    factors_of,
    read_options,
)


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "tui",
        help="the operator's terminal screen: corrections, verdict, thermal drift, history",
        description="Open a process model and a CMM report (or the newest report of a folder, "
        "re-read when a new one arrives) in a keyboard-first terminal UI. "
        "Press ? in the app for the keys.",
    )
    p.add_argument(
        "report",
        metavar="REPORT",
        nargs="?",
        type=Path,
        default=None,
        help="CMM report in any supported format, or a folder to watch",
    )
    p.add_argument("--model", metavar="MODEL", type=Path, default=None, help="process model TOML")
    p.add_argument(
        "--db",
        metavar="STORE",
        default=None,
        help="history store: a file (SQLite) or a postgresql:// URL; exports are recorded in it",
    )
    add_machine_options(p)
    p.add_argument(
        "--current",
        metavar="FILE",
        type=Path,
        default=None,
        help="the controller's current offsets (CSV register,value; a multi-axis model: "
        "register,axis,value, one row per component): new values and absolute exports; re-read "
        "when the model is switched in the app (when it does not fit, the app says so and exports "
        "changes)",
    )
    p.add_argument(
        "--link",
        metavar="LINK",
        type=Path,
        default=None,
        help="machine link file (TOML, shared/spec/machine-link.md): the current offsets are read from the "
        "control instead of --current, and w sends the cycle on screen to it (a dry-run diff, then two "
        "confirmations; the attempt is recorded with --db under --operator)",
    )
    p.add_argument(
        "--insecure",
        action="store_true",
        help="allow the link's password over an unencrypted session (refused by default)",
    )
    p.add_argument("--optimizer", default="exact", choices=sorted(OPTIMIZERS), help="optimiser to start with")
    p.add_argument(
        "--engineer",
        action="store_true",
        help="show the engineer's keys: the optimiser choice (p) and the compare tab (c, 2); "
        "without it they are hidden, and ctrl+e in the app shows them",
    )
    add_objective_option(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the metaheuristics and the comparison (default 0)")
    p.add_argument("--trials", type=int, default=12, help="trials per method in the compare view (default 12)")
    p.add_argument(
        "--offsets", metavar="FILE", default="offsets.csv", help="file the export offers to write (default offsets.csv)"
    )
    p.add_argument(
        "--process",
        metavar="LOG",
        type=Path,
        default=None,
        help="process log (CSV or .xlsx, a row per part by serial or timestamp) the diagnosis (key d) "
        "joins per part, as 'diagnose --process'",
    )
    add_factors_option(p)
    add_report_options(p)
    add_thermal_options(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from setupfix.core.errors import SetupfixError
    from setupfix.tui.app import SetupfixApp  # deferred: the CLI never loads textual otherwise
    from setupfix.tui.state import Inputs

    if args.link is not None and args.current is not None:
        raise SetupfixError("--link and --current are two sources of the current offsets: give one")

    SetupfixApp(
        Inputs(
            model=args.model,
            report=args.report,
            db=args.db,
            machine=args.machine,
            operator=args.operator,
            current=args.current,
            thermal=Path(args.thermal) if args.thermal else None,
            temperatures=Path(args.temperatures) if args.temperatures else None,
            process=args.process,
            factors=factors_of(args),
            at=args.at,
            thermal_dead_band=args.thermal_dead_band,
            read=read_options(args),
            cycles=cycles_of(args),
            optimizer=args.optimizer,
            objective=args.objective,
            seed=args.seed,
            trials=args.trials,
            offsets=args.offsets,
            engineer=args.engineer,
            link=args.link,
            insecure=args.insecure,
        )
    ).run()
    return 0
