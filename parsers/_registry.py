"""The reader registry: each format declares a :class:`FormatSpec`; dispatch picks one.

Dispatch order: an explicit ``format=`` name, then content sniffing (in priority
order), then the file extension.  A file no reader accepts is refused with the
list of formats tried.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from parsers._source import Peek, peek_file
from setupfix.errors import UnknownFormatError, SourceLocation

__all__ = ["FormatSpec", "register", "formats", "find_format", "read"]

Reader = Callable[..., pd.DataFrame]


@dataclass(frozen=True)
class FormatSpec:
    """One report format.

    Attributes
    ----------
    name : str
        Registry key, lower case (``"qif"``, ``"dmis"``, ``"calypso"``).
    description : str
        One line for ``setupfix formats``.
    extensions : tuple of str
        Lower-case suffixes with the dot (``".qif"``).
    sniff : callable(Peek) -> bool
        Pure, cheap, never raises: True when the content is of this format.
    read : callable(path, **options) -> DataFrame
        Reads the canonical measurement table. Options it may receive:
        ``unit``, ``encoding``, ``columns``; it ignores those it does not use.
    priority : int
        Sniffers run in decreasing priority (specific formats before generic ones).
    """

    name: str
    description: str
    extensions: tuple[str, ...]
    sniff: Callable[[Peek], bool]
    read: Reader
    priority: int = 0


_REGISTRY: dict[str, FormatSpec] = {}


def register(spec: FormatSpec) -> FormatSpec:
    """Add a format to the registry (a later spec of the same name replaces it)."""
    _REGISTRY[spec.name] = spec
    return spec


def formats() -> list[FormatSpec]:
    """Registered formats in sniffing order."""
    return sorted(_REGISTRY.values(), key=lambda s: (-s.priority, s.name))


def _safe_sniff(spec: FormatSpec, peek: Peek) -> bool:
    try:
        return bool(spec.sniff(peek))
    except Exception:  # noqa: BLE001 - a faulty sniffer must not stop dispatch
        return False


def find_format(path: str | Path, format: str | None = None) -> FormatSpec:
    """Choose the reader for ``path``.

    Raises
    ------
    UnknownFormatError
        If ``format`` names no reader, or no reader accepts the file.
    """
    path = Path(path)
    if format:
        try:
            return _REGISTRY[format.lower()]
        except KeyError:
            raise UnknownFormatError(
                f"unknown format {format!r} (known: {', '.join(s.name for s in formats())})",
                location=SourceLocation(str(path)),
            ) from None
    peek = peek_file(path)
    for spec in formats():
        if _safe_sniff(spec, peek):
            return spec
    for spec in formats():
        if peek.suffix in spec.extensions:
            return spec
    raise UnknownFormatError(
        f"no reader accepts this file (tried: {', '.join(s.name for s in formats())})",
        location=SourceLocation(str(path)),
        hint="name the format with --format",
    )


def read(path: str | Path, *, format: str | None = None, **options: Any) -> pd.DataFrame:
    """Read one report into the canonical measurement table (lengths in mm).

    Parameters
    ----------
    path : str or Path
        The report.
    format : str, optional
        Registry name; chosen by content, then extension, when omitted.  A column
        mapping (``columns=``) without a format means the ``table`` reader.
    **options
        ``unit``, ``encoding``, ``columns``: passed to the reader (unused ones ignored).

    Raises
    ------
    ParseError
        (or its :class:`UnknownFormatError`) naming the file and place.
    """
    if not format and options.get("columns") and "table" in _REGISTRY:
        format = "table"
    options = {k: v for k, v in options.items() if v is not None}
    return find_format(path, format).read(Path(path), **options)
