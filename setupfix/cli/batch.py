"""``setupfix batch``: every report of a folder tree corrected into one offsets file."""

from __future__ import annotations

import argparse
import signal
import sys
from types import FrameType
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
    shown,
    store_ref,
    whole_number,
)
from setupfix.cli.exit_codes import NOT_SOLVED, OK, PARTIAL, REJECTED
from setupfix.cli.machine import add_link_options

if TYPE_CHECKING:
    from setupfix.usecases.batch_records import BatchSummary, Outcome


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "batch",
        help="correct every report in a folder tree into one offsets file",
        description="Correct every report found in DIR (recursively, any supported format) and "
        "write one offsets CSV. A file that cannot be read or matched is named on "
        "stderr with its reason and skipped. Exit status 4 when any file failed, 5 "
        "when a recommendation was rejected, 6 when a solve was stopped by its "
        "time limit with nothing proven (counted in the summary, not stored as "
        "done), else 0.",
    )
    p.add_argument("folder", metavar="DIR", help="folder searched recursively for reports")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="offsets CSV (with --controller other than csv: a folder, one program per cycle)",
    )
    p.add_argument("--controller", default="csv", choices=sorted(CONTROLLERS), help="output syntax (default csv)")
    p.add_argument(
        "--current",
        metavar="FILE",
        default=None,
        help="the controller's current offsets (CSV register,value; register,axis,value in a "
        "multi-axis model): write absolute new values",
    )
    add_link_options(p, current=False)
    add_program_number_option(p)
    p.add_argument("--optimizer", default="exact", choices=sorted(OPTIMIZERS))
    p.add_argument("--seed", type=int, default=None)
    add_time_limit_option(p)
    add_objective_option(p)
    p.add_argument(
        "--workers",
        type=whole_number(1, 64),
        default=None,
        metavar="N",
        help="worker processes (default: one per available CPU, at most 8; one for fewer than 32 "
        "reports); the output does not depend on it",
    )
    p.add_argument(
        "--settle",
        type=float,
        default=1.0,
        metavar="SECONDS",
        help="a file must be unchanged this long before it is read (default 1)",
    )
    p.add_argument(
        "--store",
        metavar="DB",
        default=None,
        dest="db",
        help="history store (a file, or a postgresql:// URL shared by many machines and runs): reports "
        "it already holds are skipped, new ones are added with their recommendations; with the "
        "model's EWMA (ewma < 1) every report is smoothed over the store's parts and the batch's "
        "machined before it",
    )
    add_machine_options(p)
    p.add_argument("--force", action="store_true", help="correct reports the store already holds again")
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="with --store and the model's EWMA: the stored reports marked rejected, failed or draft enter the "
        "smoothing too (left out by default, and counted)",
    )
    p.add_argument("--json", action="store_true", help="the summary as JSON on stdout")
    add_report_options(p)
    add_thermal_options(p)
    # correct_request reads no store here: run_batch builds the history from the store and the batch's reports
    p.set_defaults(run=run, store=None)


def terminate(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt  # unwinds the atomic writer: no partial output


def run(args: argparse.Namespace) -> int:
    import json
    from contextlib import nullcontext

    from setupfix.cli.correct import correct_request
    from setupfix.inputs.smoothing import excluded_note
    from setupfix.store import excluded_reports
    from setupfix.usecases.batch import run_batch
    from setupfix.views.present import format_batch_summary

    check_program_number(args)
    request = correct_request(args)  # the very request ``correct`` builds from the same options
    ref = store_ref(args, args.db)
    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        with (
            ref.for_model(request.model).open(existing=False) if ref else nullcontext() as store,
            _Progress() as progress,
        ):
            left_out = len(excluded_reports(store)) if store is not None else 0  # before this run marks more
            summary = run_batch(
                request,
                args.folder,
                args.out,
                workers=args.workers,
                controller=args.controller,
                settle=args.settle,
                progress=progress,
                store=store,
                force=args.force,
                program_number=args.program_number,
                include_excluded=args.include_excluded,
            )
    finally:
        signal.signal(signal.SIGTERM, previous)
    for path, note in summary.notes:  # a note that names its file is printed as it is (not the path twice)
        text = str(note)
        print(f"warning: {text if text.startswith(path) else f'{path}: {text}'}", file=sys.stderr)
    if left_out:
        print(
            f"warning: {excluded_note(left_out, 'the history the reports are smoothed over', option=False)}",
            file=sys.stderr,
        )
    for path, reason in summary.failed:
        print(f"error: {reason if path in reason else f'{path}: {reason}'}", file=sys.stderr)
    if args.json:
        json.dump(summary.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_batch_summary(summary, shown(args.out)) + "\n")
        if summary.stored is not None:
            sys.stdout.write(stored_line(summary) + "\n")
    return _status(summary)


def stored_line(summary: BatchSummary) -> str:
    """What a batch with a history store stored: reports with their recommendations, and those marked excluded."""
    line = f"history store: {summary.stored} report(s) stored, each with its recommendations"
    if summary.excluded:
        n = sum(summary.excluded.values())
        why = ", ".join(f"{k} {reason}" for reason, k in sorted(summary.excluded.items()))
        line += f"; {n} of them marked excluded ({why}): left out of the history, kept for the record"
    return line


def _status(summary: BatchSummary) -> int:
    if summary.failed:
        return PARTIAL
    if summary.verdicts.get("reject"):
        return REJECTED
    if summary.unsolved:
        return NOT_SOLVED
    return OK


def _shown_verdicts(outcome: Outcome) -> list[str]:
    """Each part's verdict as the progress line shows it: NOT SOLVED for a stopped solve with nothing proven,
    and where it stopped when its rows' verdict cell says so (``apply (stopped: work limit in the … stage)``)."""
    cells = {row.part: row.verdict for row in outcome.rows}
    shown = []
    for part, verdict, solved in zip(outcome.parts, outcome.verdicts, outcome.solved, strict=False):
        cell = cells.get(part, verdict)
        if not solved:
            shown.append("NOT SOLVED" + (cell.removeprefix("not solved") if cell.startswith("not solved") else ""))
        else:
            shown.append(cell if cell.startswith(f"{verdict} (stopped") else verdict)
    return shown


class _Progress:
    """A rich progress bar (rate, ETA) on a terminal; one plain line per report otherwise (stderr)."""

    def __enter__(self) -> _Progress:
        self.bar = None
        if sys.stderr.isatty():
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.bar = Progress(
                TextColumn("batch"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("{task.fields[rate]}"),
                TimeElapsedColumn(),
                TimeRemainingColumn(),
                console=Console(file=sys.stderr),
                transient=True,
            )
            self.bar.__enter__()
            self.task = self.bar.add_task("batch", total=None, rate="")
        return self

    def __call__(self, done: int, total: int, outcome: Outcome) -> None:
        if self.bar is not None:
            elapsed = self.bar.tasks[0].elapsed or 1e-9
            self.bar.update(self.task, completed=done, total=total, rate=f"{done / elapsed:.0f} reports/s")
            return
        state = (
            "FAILED"
            if outcome.error
            else f"skipped ({outcome.skipped})"
            if outcome.skipped
            else ", ".join(_shown_verdicts(outcome)) or "no part"
        )
        print(f"[{done}/{total}] {shown(outcome.path)}: {state}", file=sys.stderr)

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
