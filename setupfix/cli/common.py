"""Options shared by the sub-commands that read reports."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any

from setupfix.core.errors import SetupfixError

#: The terms of the output, explained once (``setupfix --help``; the README repeats them).
TERMS = """\
terms (lengths in the model unit):
  deviation     actual - nominal of a dimension, as the report measured it
  margin        distance of a deviation to its nearer tolerance limit; negative when
                the dimension is out of tolerance
  error budget  the smallest margin over the measured dimensions (the unilateral
                error budget of Stryczek 2014); "before" as measured, "after" as
                predicted once the corrections are applied
  predicted     the deviation expected after the corrections: measured + the shift
                the relation matrices give for them
  bonus         error budget after - error budget before: what the corrections gain
  binding       the dimensions whose margins stop a larger error budget: no correction
                raises one of them without lowering another
"""


def shown(path: object) -> str:
    """A path (or any name) as the commands print it: printable, a name that is not UTF-8 escaped
    (``\\xff``), a control character escaped (``\\r``) — the one helper for printing paths."""
    from parsers.names import visible_name  # lazily: the command line starts without the readers

    return visible_name(str(path))


def add_objective_option(p: argparse.ArgumentParser) -> None:
    """--objective: leximin (the exact optimiser's default) or paper (eqs. 8-9)."""
    p.add_argument(
        "--objective",
        default=None,
        choices=("leximin", "paper"),
        help="what the exact optimiser maximises: leximin (default: the smallest margin, then the "
        "next smallest, and so on - every dimension centred - then the least correction) or "
        "paper (Stryczek 2014 eqs. 8-9: the smallest margin, then the least correction); "
        "the metaheuristics optimise the paper's error budget",
    )


def add_factors_option(p: argparse.ArgumentParser) -> None:
    """--factors: the declared design factors of the diagnosis (with ``--process``)."""
    p.add_argument(
        "--factors",
        metavar="A,B,A*B",
        default=None,
        help="declared design factors: process-log columns (numeric, or categorical: a coefficient per "
        "level but the first) and interactions written a*b, tested per tool register with the "
        "part as the unit, Holm over the declared terms x registers only; accepted ones enter the "
        "model, then the search runs for the rest",
    )


def factors_of(args: argparse.Namespace) -> tuple[str, ...]:
    """The ``--factors`` text as the request's tuple (empty when not given)."""
    return (args.factors,) if args.factors is not None else ()


def add_reader_options(p: argparse.ArgumentParser) -> Any:
    """The reader's options (format, unit, encoding, column mapping, lenient) in a "report reading" group."""
    g = p.add_argument_group("report reading")
    g.add_argument("--format", default=None, metavar="NAME", help="report format (default: sniffed; see 'formats')")
    g.add_argument("--unit", default=None, choices=("mm", "inch"), help="unit of values the report does not label")
    g.add_argument("--encoding", default=None, metavar="ENC", help="text encoding (default: sniffed)")
    g.add_argument(
        "--columns", default=None, metavar="MAP", help="column mapping for shop tables, e.g. actual=Meas,nominal=Nom"
    )
    add_lenient_option(g)
    return g


def add_report_options(p: argparse.ArgumentParser) -> None:
    """Reader options (:func:`add_reader_options`), then stations, cycles and strictness."""
    g = add_reader_options(p)
    g.add_argument(
        "--stations",
        default=None,
        metavar="LIST",
        help="fixture stations of the report's parts, in order (P1,P2,…) or as part=station pairs; "
        "a subset of the fixture is allowed",
    )
    g.add_argument(
        "--parts-per-cycle",
        type=whole_number(1, 10_000),
        default=None,
        metavar="N",
        help="group consecutive parts of the report N at a time into fixture loads (cycles), the k-th "
        "part of each load at the k-th of --stations (default: the model's groups when there are N)",
    )
    g.add_argument(
        "--strict",
        action="store_true",
        help="refuse a report whose nominal or tolerance of a dimension differs from the model's "
        "(default: a warning naming both values)",
    )


def add_thermal_options(p: argparse.ArgumentParser) -> None:
    """The thermal feed-forward's options (``correct``, ``batch``, ``tui``): model, log, time, dead band."""
    g = p.add_argument_group("thermal feed-forward (setupfix.usecases.thermal_feedforward)")
    g.add_argument(
        "--thermal",
        metavar="MODEL.json",
        default=None,
        help="thermal model: add the drift since the measured parts were cut",
    )
    g.add_argument("--temperatures", metavar="LOG", default=None, help="temperature log for --thermal")
    g.add_argument("--at", metavar="TIME", default=None, help="time of the correction (default: the log's last sample)")
    g.add_argument(
        "--thermal-dead-band",
        type=float,
        default=None,
        metavar="D",
        help="feed nothing forward below |D| (model unit; default one register step)",
    )


def add_machine_options(p: Any) -> None:
    """``--machine`` and ``--operator``: whose records the history store reads and writes (issue 25)."""
    p.add_argument(
        "--machine",
        default=None,
        metavar="NAME",
        help="the machine whose history is read and written (default: the model's [process] machine, else 'default')",
    )
    p.add_argument(
        "--operator",
        default=None,
        metavar="NAME",
        help="who is recorded with the stored recommendations (default: the login name)",
    )


def store_ref(args: argparse.Namespace, db: str | None) -> Any:
    """The :class:`~setupfix.inputs.stores.StoreRef` of ``db`` (a file or a postgresql:// URL) for
    ``--machine``/``--operator``; ``None`` without ``db``."""
    from setupfix.inputs.stores import StoreRef

    return None if db is None else StoreRef(str(db), args.machine, args.operator)


def add_program_number_option(p: Any) -> None:
    """``--program-number N``: the written program's number (``correct``, ``batch``)."""
    p.add_argument(
        "--program-number",
        type=whole_number(1, 99_999_999),
        default=None,
        metavar="N",
        help="number (name) of the program written: the Fanuc/Haas O number (O1-O9999 / O1-O99999), "
        "the Siemens program SETUPFIX_N; batch numbers its programs N, N+1, ... in file order "
        "(default: derived from the report and part - batch: from each program's path, distinct "
        "in a run - in O1000-O7999)",
    )


def check_program_number(args: argparse.Namespace) -> None:
    """Refuse a ``--program-number`` the chosen ``--controller`` cannot hold, before any work."""
    if getattr(args, "program_number", None) is not None:
        from setupfix.outputs.controllers import check_program_number as check

        check(args.controller, args.program_number)


def add_lenient_option(group: Any) -> None:
    """``--lenient``: the reader skips a self-contradicting row (with a warning naming its line)."""
    group.add_argument(
        "--lenient",
        action="store_true",
        help="skip a row that contradicts itself (named in a warning) instead of refusing the "
        "report; readers without such rows (all but the Korean layout) ignore it",
    )


def whole_number(low: int, high: int, allowed: str | None = None) -> Callable[[str], int]:
    """argparse type: a whole number in [low, high] (``allowed`` words the range in the message)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be {allowed or f'in [{low}, {high}]'}, got {value}")
        return value

    return parse


def positive_number(high: float) -> Callable[[str], float]:
    """argparse type: a finite number in (0, high]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not (math.isfinite(value) and 0 < value <= high):
            raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text!r}")
        return value

    return parse


def cycle_options(args: argparse.Namespace) -> dict[str, Any]:
    """Stations, parts per cycle and strictness as keyword arguments of the use cases."""
    return {"stations": parse_stations(args.stations), "parts_per_cycle": args.parts_per_cycle, "strict": args.strict}


def read_options(args: argparse.Namespace) -> Any:
    """The reader's options as a :class:`~setupfix.inputs.cycles.ReadOptions`."""
    from setupfix.inputs.cycles import ReadOptions  # not requests: that loads the optimisers

    return ReadOptions(args.format, args.unit, args.encoding, args.columns, args.lenient)


def cycles_of(args: argparse.Namespace) -> Any:
    """Stations, parts per cycle, strictness and ``--part`` as a :class:`~setupfix.usecases.requests.CycleOptions`."""
    from setupfix.usecases.requests import CycleOptions

    return CycleOptions.of(
        parse_stations(args.stations),
        parts_per_cycle=args.parts_per_cycle,
        strict=args.strict,
        part=getattr(args, "part", None),
    )


def report_options(args: argparse.Namespace) -> dict[str, Any]:
    return {
        "format": args.format,
        "unit": args.unit,
        "encoding": args.encoding,
        "columns": args.columns,
        "lenient": args.lenient,
    }


def parse_stations(text: str | None) -> list[str] | dict[str, str] | None:
    """``P1,P2`` → list; ``A7=P1,A8=P2`` → mapping part → station."""
    if not text:
        return None
    items = [t.strip() for t in text.split(",") if t.strip()]
    if all("=" in t for t in items):
        pairs = (t.split("=", 1) for t in items)
        return {part.strip(): station.strip() for part, station in pairs}
    if any("=" in t for t in items):
        raise SetupfixError(f"--stations {text!r}: give either a list (P1,P2) or pairs (part=station), not both")
    return items


def add_time_limit_option(p: argparse.ArgumentParser) -> None:
    """``--time-limit``: the wall-clock guard of the exact optimiser (shared by correct, batch and compare)."""
    p.add_argument(
        "--time-limit",
        type=float,
        default=None,
        metavar="SECONDS",
        help="wall-clock guard against a hung exact solve, per part (default 60): when it passes nothing is "
        "recommended (HOLD, not solved); the solver's stages end on work limits, so the answer does not "
        "depend on the machine's load",
    )


def emit_outcome(
    html: str | None, page: Callable[[], str], as_json: bool, doc: Callable[[], Any], text: Callable[[], str]
) -> int:
    """What ``spc`` and ``replay`` print: the page to ``--html`` (``-``: the page is the whole output, on
    stdout), then the JSON document or the text; the page's path named on stderr.  Returns 0."""
    import json
    import sys

    from setupfix.outputs.writers import write_text

    if html:
        write_text(html, page())
        if html == "-":
            return 0
    if as_json:
        json.dump(doc(), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        sys.stdout.write(text() + "\n")
    if html and html != "-":
        print(f"page → {html}", file=sys.stderr)
    return 0
