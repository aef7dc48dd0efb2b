"""``--link`` and ``--insecure`` of ``correct`` and ``batch``: the current offsets read from the control
instead of a ``--current`` file (``shared/spec/machine-link.md``)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from setupfix.model import ProcessModel
    from setupfix.usecases.requests import CurrentOffsets

__all__ = ["INSECURE_HELP", "add_link_options", "link_current"]

INSECURE_HELP = (
    "allow the link's password over an unencrypted session (refused by default: use a SignAndEncrypt security string)"
)


def add_link_options(p: argparse.ArgumentParser, *, current: bool = True) -> None:
    """``--link LINK.toml`` and ``--insecure`` (``correct``, ``batch``)."""
    p.add_argument(
        "--link",
        metavar="LINK",
        default=None,
        help="read the controller's current offsets from the control through this link file "
        "(TOML, shared/spec/machine-link.md) instead of --current: programs hold absolute values"
        + ("; --json records the values read" if current else ""),
    )
    p.add_argument("--insecure", action="store_true", help=INSECURE_HELP)


def link_current(args: argparse.Namespace, model: ProcessModel) -> CurrentOffsets | None:
    """The current offsets read through ``--link`` (None without it).

    Raises
    ------
    SetupfixError
        ``--link`` together with ``--current``; the link file invalid; the control unreachable
        (exit status 8) or a component not mapped.
    """
    from setupfix.core.errors import SetupfixError
    from setupfix.links import open_link
    from setupfix.usecases.machine import current_from_link

    if getattr(args, "link", None) is None:
        return None
    if getattr(args, "current", None) is not None:
        raise SetupfixError("--link and --current are two sources of the current offsets: give one")
    with open_link(args.link, insecure=args.insecure) as link:
        return current_from_link(link, model)
