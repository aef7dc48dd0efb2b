"""Machine links: read and write a control's offset table (``../shared/spec/machine-link.md``).

:mod:`~setupfix.links.base` is the interface (:class:`Component`, :class:`Link`),
:mod:`~setupfix.links.config` the link file, :mod:`~setupfix.links.mapping` the model's
components and the unit conversion, :mod:`~setupfix.links.opcua` the OPC UA link.
:data:`LINKS` maps a protocol name to the function that opens a link from its file;
a protocol's module (and its third-party library) is imported only when a link opens.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path

from setupfix.links.base import Component, Link
from setupfix.links.config import LinkConfig, load_link
from setupfix.links.errors import (
    LinkConfigError,
    LinkDenied,
    LinkError,
    LinkLost,
    LinkRefused,
    LinkUnconfirmed,
    LinkUnreachable,
)

__all__ = [
    "Component",
    "Link",
    "LinkConfig",
    "load_link",
    "LINKS",
    "open_link",
    "LinkError",
    "LinkConfigError",
    "LinkUnreachable",
    "LinkLost",
    "LinkDenied",
    "LinkRefused",
    "LinkUnconfirmed",
]

Opener = Callable[[LinkConfig], Link]


def _lazy(target: str) -> Opener:
    """An opener that imports ``module:function`` when first called."""
    module, _, function = target.partition(":")

    def opener(config: LinkConfig) -> Link:
        found: Opener = getattr(importlib.import_module(module), function)
        return found(config)

    return opener


#: Protocol name → opener(config) -> Link.  A new protocol adds its entry (and its name to
#: :data:`setupfix.links.config.PROTOCOLS`).
LINKS: dict[str, Opener] = {
    "opcua": _lazy("setupfix.links.opcua:open_opcua"),
    "linuxcnc": _lazy("setupfix.links.linuxcnc:open_linuxcnc"),
}


def open_link(link: LinkConfig | str | Path, *, insecure: bool = False) -> Link:
    """Open the link a file (or a loaded config) describes.

    Raises
    ------
    LinkConfigError
        An invalid file, or a password over an unencrypted session without ``insecure``.
    LinkUnreachable
        The control does not answer (protocols that connect at open).
    """
    config = link if isinstance(link, LinkConfig) else load_link(link)
    if insecure and not config.insecure:
        config = config.with_insecure(True)
    return LINKS[config.protocol](config)
