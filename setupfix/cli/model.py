"""``setupfix model show | check | init | map``: inspect a process model, tie a report to it, scaffold one,
answer a scaffold's questions."""

from __future__ import annotations

import argparse
import json
import math
import sys
import textwrap
import unicodedata
from pathlib import Path
from typing import TYPE_CHECKING

from setupfix.cli.common import add_reader_options, add_report_options, cycle_options, read_options, report_options
from setupfix.core.errors import ExportError, SourceLocation

if TYPE_CHECKING:
    from setupfix.model import ProcessModel
    from setupfix.usecases.model_check import MatchTable

MATRICES = ("R_MW", "R_WF", "R_TF", "R_FD", "C")
#: Terminal width the human tables are laid out for.
WIDTH = 100


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "model",
        help="inspect a process model, check a report against it, or scaffold one",
        description="Process model files (shared/spec/process-model.md): show its matrices, "
        "check how a report matches it, or write a scaffold from reports.",
    )
    msub = p.add_subparsers(dest="model_command", metavar="ACTION", parser_class=type(p))
    show = msub.add_parser(
        "show",
        help="print R_MW, R_WF, R_TF, R_FD, the composite, its rank and null space",
        description="The relation matrices of the model (Stryczek 2014, eqs. 3-4) labelled "
        "like the paper, the composite C (registers x dimensions), its rank and the "
        "corrections that move no dimension (null space).",
    )
    show.add_argument("model", metavar="MODEL", help="process model TOML")
    show.add_argument(
        "--matrix", action="append", choices=MATRICES, default=None, help="only this matrix (repeatable; default all)"
    )
    show.add_argument("--json", action="store_true", help="matrices, rank and null space as JSON")
    show.set_defaults(run=run_show)

    check = msub.add_parser(
        "check",
        help="the match table of a report against the model (nothing corrected)",
        description="Ties every characteristic of the report to a model dimension as "
        "'correct' would and prints, per dimension, the report's name, nominal "
        "and limits beside the model's; unmatched report names with the closest "
        "model names; absent dimensions with the closest report names; and the "
        "differences 'correct' warns about.",
    )
    check.add_argument("model", metavar="MODEL", help="process model TOML")
    check.add_argument("report", metavar="REPORT", help="CMM report in any supported format")
    check.add_argument("--json", action="store_true", help="the match table as JSON (every name, in full)")
    add_report_options(check)
    check.set_defaults(run=run_check)

    init = msub.add_parser(
        "init",
        help="write a draft model scaffold from reports (then check and edit it)",
        description="Every toleranced length characteristic of the reports becomes a "
        "dimension (name, nominal, limits, group = station). Several measured axes (or "
        "sizes cut by interpolation, or position callouts) give a multi-axis model with a "
        "feature per feature of the part at its position: a location follows its feature "
        "along the axis or direction the report states, a distance is the difference of "
        "its two features, a size moves only with a tool radius where the report's feature "
        "type says it is interpolated, a position callout is a circular zone. Which work "
        "offset and tool made each feature the reports do not say: each is a named "
        "question for 'model map'. A one-axis model moves each feature by W1 (G54) and, "
        "on the spindle axis, T1 (H1). The file is marked draft = true: 'correct' holds "
        "until the questions are answered and the physics checked; its comments say what "
        "to check.",
    )
    init.add_argument(
        "reports",
        nargs="+",
        metavar="REPORT",
        help="CMM report(s) in any supported format; a folder stands for the reports in it and its "
        "sub-folders (hidden, partial and log files and models left out; a link to a folder or "
        "an unreadable one named in a warning)",
    )
    init.add_argument(
        "-o", "--out", required=True, metavar="MODEL", help="model TOML to write ('-': stdout); written atomically"
    )
    init.add_argument(
        "--axis",
        choices=("X", "Y", "Z"),
        default=None,
        help="a one-axis model: keep the characteristics along this axis (as the report states it, "
        "else the name) and those with none; default: keep all, a multi-axis model when the "
        "reports measure several axes, else a one-axis model on the one they state",
    )
    init.add_argument("--name", default=None, help="process name (default: from the report file names)")
    init.add_argument(
        "--parts-are-stations",
        action="store_true",
        help="the report's parts are the fixture's stations (one workpiece each): group = part "
        "(default: group = the report's station, if it gives one)",
    )
    init.add_argument(
        "--force",
        action="store_true",
        help="replace MODEL if it exists (default: refuse, so an edited model is never overwritten)",
    )
    init.add_argument(
        "--answer",
        action="append",
        default=[],
        metavar="SEL=WKS,TOOL",
        help="answer questions at once, as 'model map --answer' does (e.g. '*=G54,T1': every feature made on "
        "G54 by tool 1); the scaffold stays a draft",
    )
    init.add_argument("--answers", metavar="CSV", default=None, help="answers from a CSV (feature, wks, tool)")
    add_reader_options(init)
    init.set_defaults(run=run_init)

    mapping = msub.add_parser(
        "map",
        help="answer a scaffold's questions: which work offset and tool made each feature",
        description="Lists the features of a model init scaffold with their positions and callouts, "
        "and the questions the reports leave open: which work offset (WKS) and which tool made each "
        "feature. Answers (--answer, or a CSV with --answers) are written into the model: the feature's "
        "wks and tool length relations, a size's tool radius, the register tables they name; when the "
        "last question is answered, draft = true goes too. Written atomically; nothing is written when "
        "an answer is refused.",
    )
    mapping.add_argument("model", metavar="MODEL", help="process model TOML (a model init scaffold)")
    mapping.add_argument(
        "--answer",
        action="append",
        default=[],
        metavar="SEL=WKS,TOOL",
        help="answer the questions SEL selects (a question Q1, a feature F1, a report feature or callout "
        "name, a pattern DIAMETER5*, group:P1, or *; several with commas): made on WKS (G54, an ID, or "
        "none) by TOOL (T5, H5, 5, or none); a size only asks for the tool (SEL=,T5); repeatable, a "
        "narrower selector wins",
    )
    mapping.add_argument(
        "--answers", metavar="CSV", default=None, help="answers from a CSV file with the columns feature, wks, tool"
    )
    mapping.add_argument("-o", "--out", metavar="MODEL", default=None, help="write here (default: MODEL itself)")
    mapping.add_argument(
        "--keep-draft", action="store_true", help="keep draft = true even when every question is answered"
    )
    mapping.add_argument("--json", action="store_true", help="the listing (or what was written) as JSON")
    mapping.add_argument("--tui", action="store_true", help="answer in the terminal UI")
    mapping.set_defaults(run=run_map)


def run_init(args: argparse.Namespace) -> int:
    from setupfix.outputs.writers import check_target, write_text
    from setupfix.usecases.model_init import scaffold_model
    from setupfix.usecases.model_map import parse_answer, read_answers

    check_target(args.out)
    if args.out != "-" and Path(args.out).exists() and not args.force:
        raise ExportError(
            "exists: a scaffold would replace it (give --force, or another -o)", location=SourceLocation(args.out)
        )
    answers = read_answers(args.answers) if args.answers else []
    for i, spec in enumerate(args.answer, start=1):
        answers += parse_answer(spec, SourceLocation(f"--answer #{i}"))
    scaffold = scaffold_model(
        args.reports,
        axis=args.axis,
        name=args.name,
        parts_are_stations=args.parts_are_stations,
        read=read_options(args),
        answers=answers,
    )
    for note in scaffold.notes:
        print(f"warning: {note}", file=sys.stderr)
    write_text(args.out, scaffold.text + "\n")
    if args.out != "-":
        origins = ", ".join(
            f"{n} {what}"
            for what, n in (
                ("stated by the report", scaffold.axes_from.get("report", 0)),
                ("from names", scaffold.axes_from.get("name", 0)),
                ("with none", scaffold.axes_from.get("none", 0)),
            )
            if n
        )
        axes = f"axes {', '.join(scaffold.axes)} (multi-axis)" if scaffold.axes else f"process axis {scaffold.axis}"
        sizes = f", {scaffold.sizes} size(s)" if scaffold.sizes else ""
        axes += f", {scaffold.zones} position zone(s)" if scaffold.zones else ""
        axes += f", {scaffold.distances} distance(s)" if scaffold.distances else ""
        if scaffold.questions:
            todo = (
                f"with {len(scaffold.questions)} question(s) open (which work offset and tool made each feature): "
                f"answer them with 'setupfix model map {args.out}', then 'setupfix model check' and 'setupfix correct'"
            )
        else:
            todo = (
                "('correct' holds until you remove 'draft = true'): check its registers and relations, then "
                "'setupfix model check' and 'setupfix correct'"
            )
        print(
            f"wrote {args.out}: {scaffold.dimensions} dimension(s) (axes: {origins}{sizes}), {axes}, "
            f"{len(scaffold.skipped)} characteristic(s) left out (listed in its head); it is a draft {todo}",
            file=sys.stderr,
        )
    return 0


def run_map(args: argparse.Namespace) -> int:
    from setupfix.usecases.model_map import answer_questions, map_listing, parse_answer, read_answers
    from setupfix.views.model_map import format_listing, format_result

    if args.tui:
        from setupfix.tui.screens.model_map import run_model_map

        return run_model_map(args.model, out=args.out, keep_draft=args.keep_draft)
    answers = read_answers(args.answers) if args.answers else []
    for i, spec in enumerate(args.answer, start=1):
        answers += parse_answer(spec, SourceLocation(f"--answer #{i}"))
    if not answers:
        listing = map_listing(args.model)
        if args.json:
            json.dump(listing.to_json(), sys.stdout, indent=1)
            sys.stdout.write("\n")
        else:
            sys.stdout.write(format_listing(listing) + "\n")
        return 0
    result = answer_questions(args.model, answers, out=args.out, keep_draft=args.keep_draft)
    if args.json:
        json.dump(
            {
                "model": str(args.out or args.model),
                "answered": [{"question": q, "wks": w, "tool": t} for q, w, t in result.answered],
                "remaining": list(result.remaining),
                "added": list(result.added),
                "draft": result.draft,
            },
            sys.stdout,
            indent=1,
        )
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_result(result, str(args.out or args.model)) + "\n")
    return 0


def run_show(args: argparse.Namespace) -> int:
    from setupfix.usecases.model_check import describe_model
    from setupfix.views.present import format_relations

    desc = describe_model(args.model)
    if args.json:
        json.dump(desc.to_json(), sys.stdout, indent=1)
        sys.stdout.write("\n")
        return 0
    which = args.matrix or [m for m in MATRICES if m != "R_MW" or desc.matrices.R_MW.size]
    sys.stdout.write(f"{_safe(desc.model.name)}  ({_axes_of(desc.model)}, unit {desc.model.unit}, ")
    sys.stdout.write(f"resolution {desc.model.resolution:g})\n\n")
    sys.stdout.write(format_relations(desc.matrices, which, desc.null_space, desc.rank) + "\n")
    return 0


def _axes_of(model: ProcessModel) -> str:
    """What a model corrects along: ``axis Z``, or ``axes X, Y, Z, spindle Z, rotation C (W1, W2), tool radius``."""
    if not model.multi_axis:
        return f"axis {model.axis}"
    rotating = [w.base for w in model.wks if w.component == "C"]
    turn = f", rotation C ({', '.join(dict.fromkeys(rotating))})" if rotating else ""
    radius = ", tool radius" if any(t.component == "R" for t in model.tools) else ""
    return f"axes {', '.join(model.axes)}, spindle {model.spindle}{turn}{radius}"


def run_check(args: argparse.Namespace) -> int:
    from setupfix.usecases.model_check import check_report

    table = check_report(args.model, args.report, **cycle_options(args), **report_options(args))
    if args.json:
        json.dump(table.to_json(), sys.stdout, indent=1)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(format_match_table(table) + "\n")
    return 0


def _safe(text: str) -> str:
    """Report text for the terminal: control characters (escape sequences) shown as "?"."""
    return "".join(c if c.isprintable() else "?" for c in text)


def cells(text: str) -> int:
    """Terminal cells of a text: East Asian wide and full-width characters take two."""
    return sum(2 if unicodedata.east_asian_width(c) in "WF" else 1 for c in text)


def cut(text: str | None, width: int) -> str:
    """The text cut to ``width`` terminal cells (with "…") and padded to exactly that width."""
    text = "—" if not text else "".join(c if c.isprintable() else "?" for c in text)
    if cells(text) > width:
        while cells(text) > width - 1:
            text = text[:-1]
        text += "…"
    return text + " " * (width - cells(text))


def _n(value: float | None) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:.6g}"


def _limits(lower: float | None, upper: float | None) -> str:
    return f"{_n(lower)}/{'+' if upper is not None and upper > 0 else ''}{_n(upper)}"


def format_match_table(table: MatchTable) -> str:
    """The match table, one block per part, at most :data:`WIDTH` columns."""
    unit = table.model.unit
    blocks = []
    for part in table.parts:
        rows = table.rows(part)
        n_dims = len(rows)
        lines = [
            _safe(f"{table.report}  part {part.part or '—'}:"),
            f"{int(part.measured.sum())} of {n_dims} model dimensions matched, "
            f"{len(part.unmatched)} report characteristic(s) unmatched",
            "",
        ]
        name_w = min(22, max([len("dimension")] + [cells(r["name"]) for r in rows]))
        char_w = min(22, max([len("report name")] + [cells(r["characteristic"] or "") for r in rows]))
        longest = max([0] + [len(r["station"] or "") for r in rows])
        st_w = min(10, max(len("station"), longest)) + 1 if longest else 0
        head = (
            f"{'station':<{st_w}}"[:st_w] + f"{'dimension':<{name_w}} {'report name':<{char_w}} "
            f"{'nominal':>10} {'report':>10}  {'limits [' + unit + ']':<15} {'report':<15}"
        )
        lines += [head.rstrip(), "-" * min(WIDTH, len(head.rstrip()))]
        for r in rows:
            lead = (cut(r["station"], st_w - 1) + " " if st_w else "") + cut(r["name"], name_w) + " "
            if not r["matched"]:
                near = _safe(", ".join(r["closest"]))
                lines.append(lead + "absent from the report" + (f"; closest report names: {near}" if near else ""))
                continue
            lines.append(
                (
                    lead + f"{cut(r['characteristic'], char_w)} {_n(r['nominal']):>10} "
                    f"{_n(r['report_nominal']):>10}  {_limits(r['lower'], r['upper']):<15} "
                    f"{_limits(r['report_lower'], r['report_upper']):<15}" + (" ≠" if r["differs"] else "")
                ).rstrip()
            )
        if part.unmatched:
            lines += ["", "report characteristics matching no dimension (closest model names):"]
            for unmatched in part.unmatched:
                closest = part.suggestions.get(unmatched, ())
                lines.append(
                    f"  {_safe(unmatched)}"
                    + (f"  →  {', '.join(map(_safe, closest))}" if closest else "  (nothing close)")
                )
        if part.notes:
            lines += [""] + [
                textwrap.fill(_safe(f"warning: {n}"), WIDTH, subsequent_indent="  ", break_on_hyphens=False)
                for n in part.notes
            ]
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)
