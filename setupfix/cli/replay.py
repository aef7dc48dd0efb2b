"""``setupfix replay``: a rule set run over a machine's stored history, next to what happened."""

from __future__ import annotations

import argparse
from pathlib import Path

from setupfix.cli.common import emit_outcome
from setupfix.core.errors import ParameterError, SourceLocation, StoreError

#: ``--grid`` keys and how their alternatives are read.
GRID_KEYS = ("dead_band", "gain", "mean_of")


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "replay",
        help="what a rule set (dead band %%, gain, mean of n, min parts) would have done over the stored history",
        description="Replays the stored history in time order under a rule set: each part's deviations minus "
        "the corrections applied plus those the rules would have applied, through the model's relation "
        "matrices.  Prints the values out of tolerance, parts at risk, corrections and their size and the "
        "lowest Cpk, next to what happened.  The replay assumes the model; the model's walk-forward error "
        "is shown beside it (histories up to 400 parts).",
    )
    p.add_argument(
        "--db",
        metavar="STORE",
        default=None,
        help="history store: a file (SQLite) or a postgresql:// URL (default: $SETUPFIX_DB, else setupfix.db here)",
    )
    p.add_argument("--machine", metavar="NAME", default=None, help="the machine whose history is replayed")
    p.add_argument("--model", required=True, metavar="MODEL", help="process model TOML")
    p.add_argument(
        "--rules",
        metavar="RULES",
        default=None,
        help="the rule set, e.g. 'dead_band=10 %%,gain=0.5,mean_of=3,min_parts=2' (default: the model's [safety])",
    )
    p.add_argument(
        "--grid",
        metavar="GRID",
        nargs="?",
        const="",
        default=None,
        help="also try a grid and name the best: 'dead_band=5 %%|10 %%,gain=0.5|1,mean_of=1|3' (alone: "
        "dead band none|5|10|20 %% × gain 0.5|0.7|1 × mean_of 1|3|5)",
    )
    p.add_argument(
        "--include-excluded",
        action="store_true",
        help="take in the reports the store keeps marked rejected, failed or draft (left out by default)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--html", metavar="OUT", default=None, help="also write the page with the before/after charts ('-': stdout)"
    )
    p.set_defaults(run=run)


def parse_grid(text: str) -> tuple[tuple[float | None, ...], tuple[float, ...], tuple[int, ...]] | None:
    """``dead_band=5 %|10 %,gain=0.5|1,mean_of=1|3`` → (shares, gains, means); ``""`` → None (the default grid)."""
    from setupfix.usecases.replay import DEFAULT_GRID

    if not text.strip():
        return None
    shares, gains, means = DEFAULT_GRID
    seen: set[str] = set()
    for item in text.split(","):
        key, eq, values = item.partition("=")
        key = key.strip()
        if not eq or key not in GRID_KEYS or key in seen:
            raise ParameterError(
                f"replay --grid {text!r}: {item.strip()!r} is not one of {', '.join(GRID_KEYS)}=A|B|… (each once)"
            )
        seen.add(key)
        options = [v.strip() for v in values.split("|") if v.strip()]
        try:
            if key == "dead_band":
                shares = tuple(_share(v) for v in options)
            elif key == "gain":
                gains = tuple(float(v) for v in options)
            else:
                means = tuple(int(v) for v in options)
        except ValueError:
            raise ParameterError(f"replay --grid {text!r}: {key} takes numbers ({values.strip()!r})") from None
        if not options:
            raise ParameterError(f"replay --grid {text!r}: {key} has no value")
    return shares, gains, means


def _share(text: str) -> float | None:
    if text.lower() in ("none", "off", "0", "0 %", "0%"):
        return None
    if not text.endswith("%"):
        raise ValueError(text)
    return float(text[:-1].strip()) / 100


def run(args: argparse.Namespace) -> int:
    from setupfix.inputs.stores import StoreRef
    from setupfix.model.safety import parse_rules
    from setupfix.outputs.writers import check_target
    from setupfix.store import is_server
    from setupfix.usecases.history import store_location
    from setupfix.usecases.replay import ReplayRequest, format_replay, replay_history, replay_json
    from setupfix.views.replay_html import replay_page

    location = store_location(args.db)
    if args.html == "-" and args.json:
        raise ParameterError("replay: --html - and --json would both write to standard output")
    if args.html:
        check_target(args.html)
    if not is_server(location) and not Path(location).is_file():
        raise StoreError(
            "no history store here",
            location=SourceLocation(location),
            hint="create it with 'setupfix history import', or give --db",
        )
    rules = parse_rules(args.rules) if args.rules is not None else None
    grid = parse_grid(args.grid) if args.grid is not None else None
    request = ReplayRequest(
        StoreRef(location, args.machine),
        args.model,
        rules,
        grid=args.grid is not None,
        grid_values=grid,
        include_excluded=args.include_excluded,
    )
    outcome = replay_history(request)
    return emit_outcome(
        args.html,
        lambda: replay_page(outcome),
        args.json,
        lambda: replay_json(outcome),
        lambda: format_replay(outcome),
    )
