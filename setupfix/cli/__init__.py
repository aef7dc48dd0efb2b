"""Command line: ``setupfix <command> …``.

This module is the single error boundary: a :class:`~setupfix.core.errors.SetupfixError`
becomes one line on stderr and exit status 1, a usage error exit status 2, an
unexpected exception one line naming it and exit status 3 (never a traceback),
Ctrl-C exit status 130.  Sub-commands live one per module, each with
``add_parser(subparsers)`` and ``run(args) -> int``; they hold no computation, only
calls into :mod:`setupfix.usecases`.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import TextIO

from setupfix import __version__
from setupfix.cli.common import TERMS
from setupfix.cli.exit_codes import ERROR, INTERRUPTED, UNEXPECTED, USAGE
from setupfix.core.errors import SetupfixError

__all__ = ["main", "build_parser"]

#: Sub-command modules, in the order ``--help`` lists them.
COMMAND_MODULES: tuple[str, ...] = (
    "setupfix.cli.correct",
    "setupfix.cli.batch",
    "setupfix.cli.parse",
    "setupfix.cli.formats",
    "setupfix.cli.compare",
    "setupfix.cli.model",
    "setupfix.cli.thermal",
    "setupfix.cli.history",
    "setupfix.cli.simulate",
    "setupfix.cli.diagnose",
    "setupfix.cli.spc",
    "setupfix.cli.replay",
    "setupfix.cli.tui",
    "setupfix.cli.machine",
)


class _Parser(argparse.ArgumentParser):
    """argparse that raises instead of exiting, so ``main`` owns every exit."""

    def error(self, message: str) -> None:  # type: ignore[override]  # raises; argparse declares NoReturn
        raise _UsageError(f"{self.prog}: {message}")


class _UsageError(Exception):
    pass


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser with every registered sub-command."""
    parser = _Parser(
        prog="setupfix",
        description=__doc__.splitlines()[0] if __doc__ else None,
        epilog=TERMS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"setupfix {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    for command in sub.choices.values():
        if command.get_default("run") is None:  # a group such as "thermal" given without its action
            command.set_defaults(run=_usage(command))
    return parser


def _usage(parser: argparse.ArgumentParser) -> Callable[[argparse.Namespace], int]:
    def show(_: argparse.Namespace) -> int:
        parser.print_help(sys.stderr)
        return USAGE

    return show


def _one_line_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Warnings reach the operator as one ``warning:`` line on stderr, without source code."""
    print(f"warning: {message}", file=sys.stderr)


def _safe_streams() -> None:
    """Standard output and error never fail on a character they cannot encode (a file name that
    is not UTF-8 is shown escaped, never an ``internal error``); names the commands print go through
    :func:`setupfix.cli.common.shown` first, this is the net below it."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None and getattr(stream, "errors", "") in ("strict", None):
            with contextlib.suppress(ValueError, OSError):  # a stream that cannot change: left as it is
                reconfigure(errors="backslashreplace")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    _safe_streams()
    with warnings.catch_warnings():
        warnings.showwarning = _one_line_warning
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "run", None):
            parser.print_help(sys.stderr)
            return USAGE
        return int(args.run(args))
    except _UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return USAGE
    except SetupfixError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return int(getattr(exc, "exit_status", ERROR))  # a machine link's error carries its own (6, 7, 8)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return INTERRUPTED
    except BrokenPipeError:
        return ERROR
    except SystemExit as exc:  # --help and --version end argparse with SystemExit(0)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else ERROR)
    except Exception as exc:  # noqa: BLE001 - the boundary: never a traceback
        print(f"internal error: {type(exc).__name__}: {exc} (please report)", file=sys.stderr)
        return UNEXPECTED
