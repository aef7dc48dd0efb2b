"""``setupfix diagnose``: the residual of a series, the effects it traces to, error before and after."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import TYPE_CHECKING

from setupfix.cli.common import (
    add_factors_option,
    add_lenient_option,
    add_machine_options,
    add_objective_option,
    factors_of,
    store_ref,
)
from setupfix.cli.exit_codes import OK
from setupfix.core.errors import SetupfixError

if TYPE_CHECKING:
    from setupfix.usecases.diagnosis import DiagnoseOutcome

__all__ = ["add_parser", "run"]


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "diagnose",
        help="find what the model lacks in a series of reports; error before and after",
        description="Fit the declared model to a series of reports (setup state, corrections in effect at each "
        "part's timestamp), trace the residual to effects the model lacks (drift, thermal, wear, "
        "scale, position, relation, group, level, process) by forward selection with F-tests and "
        "cross-validation, "
        "report the error before and after, walk forward against EWMA and no correction, and "
        "recommend the next correction.",
    )
    p.add_argument(
        "reports",
        nargs="*",
        metavar="REPORT",
        help="report files or folders: one series of cycles; a folder stands for the reports in it and "
        "its sub-folders (hidden, partial files and models left out; a link to a folder or an "
        "unreadable one named in a note) and its corrections.csv / temperatures.csv are used "
        "unless --corrections / --temperatures are given",
    )
    p.add_argument(
        "--db",
        metavar="STORE",
        default=None,
        help="history store (a file, or a postgresql:// URL): the machine's reports, corrections log and "
        "temperatures (see 'setupfix history')",
    )
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument(
        "--corrections",
        metavar="CSV",
        default=None,
        help="corrections log (timestamp,register,delta[,event]; header in any case)",
    )
    p.add_argument("--temperatures", metavar="CSV", default=None, help="temperature log")
    p.add_argument(
        "--process",
        metavar="LOG.csv",
        default=None,
        help="process log: a 'serial' column (the parts' numbers) or a 'timestamp' column, and channels "
        "of any name and unit (numeric, or categorical: one 0/1 indicator per level), each tested "
        "as acting on one register or on every tool alike",
    )
    add_factors_option(p)
    p.add_argument(
        "--thermal",
        metavar="MODEL.json",
        default=None,
        help="thermal model saved by 'setupfix thermal fit': its predicted drift is tested as a channel",
    )
    p.add_argument(
        "--augment",
        metavar="OUT.toml",
        default=None,
        help="write the model with the effects found as its [effects] section",
    )
    p.add_argument("--alpha", type=float, default=0.01, help="family-wise level of each selection step (0.01)")
    p.add_argument("--no-walk", action="store_true", help="skip the walk-forward comparison")
    p.add_argument(
        "--score-from",
        type=int,
        metavar="N",
        default=None,
        help="score the walk forward from cycle N on (default: the first from which the search's choice is stable; "
        "the cycles before are its learning, scored apart)",
    )
    add_lenient_option(p)
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="with --db: take in the reports the store keeps marked rejected, failed or draft (left out by "
        "default, and counted)",
    )
    p.add_argument("--verbose", action="store_true", help="show every note (default: at most five)")
    p.add_argument("--json", action="store_true", help="machine-readable output (shared/spec/cli-json.md)")
    add_objective_option(p)
    add_machine_options(p)
    p.set_defaults(run=run)


def _f(v: float | None, digits: int = 4) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def format_diagnosis(out: DiagnoseOutcome, verbose: bool = False) -> str:
    """Human summary of a diagnosis: at most :data:`~setupfix.views.analysis.MAX_NOTES` notes unless ``verbose``."""
    from setupfix.views.analysis import MAX_NOTES, assumed_conditions, draft_next, level_words, next_correction_text

    d = out.diagnosis
    unit = d.layout.unit
    lines = [
        f"{d.series.n_cycles} cycle(s), {len(d.layout.dimension_ids)} dimension(s)",
        f"residual of the declared model: RMS {_f(d.error_before.rms)} {unit}, max {_f(d.error_before.max)}, "
        f"out of tolerance {d.error_before.out_of_tolerance}",
    ]
    if d.factors is not None and d.factors.family == "log":
        taken = [t for t in d.factors.tests if t.accepted]
        lines.append(
            f"process log columns tested first ({len(d.factors.terms)} columns, {len(d.factors.tests)} tests in "
            "steps; p from permutations of the parts, adjusted over each step): "
            + (", ".join(f"{t.term.name} on {t.register} (adjusted p {t.p_holm:.2g})" for t in taken) or "none taken")
        )
    elif d.factors is not None:
        lines.append(
            f"declared factors ({len(d.factors.tests)} tests, the part as the unit; p Holm-adjusted over them):"
        )
        for t in d.factors.tests:
            lines.append(
                f"  {t.term.name:30s} {t.register:6s} p {t.p:.2g}, adjusted {t.p_holm:.2g}"
                + ("   accepted" if t.accepted else "")
            )
    if d.effects:
        lines.append("effects the model lacks:")
        for e in d.effects:
            who = "from the log" if e.source == "log" else "declared"
            how = (
                ""
                if e.source == "search"
                else (f"   {who}, p {e.p:.2g}" if e.p is not None else f"   {who}, with its interaction")
            )
            lines.append(
                f"  {e.kind:9s} {e.target:40s} {e.estimate:+.4g} ± {e.stderr:.2g} {e.unit}"
                f"   (RMS after {_f(e.rms_after)}){how}"
            )
            words = level_words(e.spec, d.series)
            if words is not None:
                lines.append(f"            {words}")
            if e.alike:
                lines.append(f"            cannot be told apart from: {', '.join(e.alike)}")
        lines.append(
            f"residual with them: RMS {_f(d.error_after.rms)} {unit}, max {_f(d.error_after.max)}, "
            f"out of tolerance {d.error_after.out_of_tolerance}"
        )
    else:
        lines.append(
            "no effect found"
            + ("" if d.selection.lack_of_fit else ": the declared model explains the series to its noise")
        )
    if d.walk is not None:
        start = f" from cycle {d.walk.scored_from + 1}" if d.walk.scored_from is not None else ""
        lines.append(
            f"walk forward over {len(d.walk.cycles)} cycle(s){start} (error budget: mean / worst; RMS reached; "
            "distance to the tolerance centre: RMS / mean |.|):"
        )
        for name, b in d.walk.budgets.items():
            lines.append(
                f"  {name:9s} {_f(b.mean_budget)} / {_f(b.worst_budget)}   RMS {_f(b.rms)}   "
                f"centre {_f(b.centre_rms)} / {_f(b.centre_mean_abs)}   "
                f"out of tolerance {b.out_of_tolerance}"
            )
        if d.walk.whole is not None:
            lines.append(
                f"  over all {len(d.walk.walked)} cycle(s) walked, learning included: centre RMS "
                + ", ".join(f"{name} {_f(b.centre_rms)}" for name, b in d.walk.whole.items())
            )
    lines.append(
        f"next correction from: {d.next_from.source}" + (f" ({d.next_from.reason})" if d.next_from.reason else "")
    )
    draft = draft_next(out)
    if draft is not None:  # no number and no "none": the draft is said as ``correct`` says it
        lines.append(f"next correction: {draft}")
    else:
        lines.append("next correction: " + next_correction_text(out.input.model, out.next_correction))
        assumed = assumed_conditions(out)
        if assumed is not None:
            lines.append(assumed)
    if out.augmented:
        lines.append(f"wrote {out.augmented}")
    # a folder's problems are warnings (always shown); the draft is said on the next-correction line
    lines += [f"warning: {n}" for n in out.notes if n.kind == "folder"]
    notes = [f"note: {n}" for n in out.notes if n.kind not in ("folder", "draft")]
    shown = notes if verbose else notes[:MAX_NOTES]
    lines += shown
    if len(shown) < len(notes):
        lines.append(f"... and {len(notes) - len(shown)} more note(s): --verbose shows them")
    # report text (characteristic names, file names) reaches the terminal: no escape sequences
    return "\n".join("".join(c if c.isprintable() else "?" for c in line) for line in lines)


def run(args: argparse.Namespace) -> int:
    from setupfix.diagnose import Diagnoser
    from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports
    from setupfix.usecases.requests import ReadOptions, SolveOptions

    if not args.reports and not args.db:
        raise SetupfixError("diagnose: give REPORT files or folders, or --db STORE")
    out = diagnose_reports(
        DiagnoseRequest(
            args.model,
            tuple(args.reports),
            ReadOptions(lenient=args.lenient),
            corrections=args.corrections,
            temperatures=args.temperatures,
            db=store_ref(args, args.db),
            thermal=args.thermal,
            augment=args.augment,
            process=args.process,
            factors=factors_of(args),
            diagnoser=Diagnoser(alpha=args.alpha, walk=not args.no_walk, score_from=args.score_from),
            solve=SolveOptions(objective=args.objective),
            include_excluded=args.include_excluded,
        )
    )
    if args.json:
        json.dump(out.to_json(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_diagnosis(out, verbose=args.verbose) + "\n")
    return OK
