"""The reader registry: each format declares a :class:`FormatSpec`; dispatch picks one.

Dispatch order: an explicit ``format=`` name, then content sniffing (in priority
order), then the file extension.  A file no reader accepts is refused with the
list of formats tried.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from parsers.names import visible_name
from parsers.notes import collecting
from parsers.rowkeys import row_keys
from parsers.source import NO_FINAL_LINE_BREAK, Peek, Source, load_source, peek
from parsers.verdicts import verdict_notes
from setupfix.core.errors import (
    Note,
    ParameterError,
    ParseError,
    ParseWarning,
    SetupfixError,
    SourceLocation,
    UnknownFormatError,
)

__all__ = ["FormatSpec", "ReadResult", "register", "formats", "find_format", "read", "read_report", "OPTIONS"]

#: Every option a reader may be given; each :class:`FormatSpec` declares the ones it uses.
OPTIONS = ("unit", "encoding", "columns", "lenient")

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
    read : callable(source, **options) -> DataFrame
        Reads the canonical measurement table from a :class:`~parsers.source.Source`
        (the bytes read once); leaves its notes with :func:`parsers.notes.note`.
    priority : int
        Sniffers run in decreasing priority (specific formats before generic ones).
    options : tuple of str
        The options of :data:`OPTIONS` the reader uses; any other given is refused.
    complete : callable(bytes) -> str or None, optional
        Whether the bytes are a whole file as the format's writers end it (a final line
        break, an ``ENDFIL``/``END`` statement): None when so, else what is missing.  A
        file that fails it is refused as possibly truncated (issue 10).  Formats whose
        parser refuses a cut file anyway (XML, JSON, zip) leave it None.
    """

    name: str
    description: str
    extensions: tuple[str, ...]
    sniff: Callable[[Peek], bool]
    read: Reader
    priority: int = 0
    options: tuple[str, ...] = ("unit", "encoding")
    complete: Callable[[bytes], str | None] | None = None


@dataclass(frozen=True)
class ReadResult:
    """One report read: the canonical table and the notes the reader left (skipped rows, assumed units).

    Attributes
    ----------
    table : DataFrame
        Canonical measurement table, lengths in mm.
    notes : tuple of Note
        Warnings as data, each with its file and line/element.
    format : str
        The registry name of the reader used.
    source : str
        The input's name as given (``-`` for stdin).
    """

    table: pd.DataFrame
    notes: tuple[Note, ...] = ()
    format: str = ""
    source: str = ""


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


def find_format(path: str | Path | Source, format: str | None = None) -> FormatSpec:
    """Choose the reader for ``path`` (a path is read once; pass a :class:`Source` to reuse its bytes).

    Raises
    ------
    UnknownFormatError
        If ``format`` names no reader, or no reader accepts the file.
    """
    if format:
        try:
            return _REGISTRY[format.lower()]
        except KeyError:
            raise UnknownFormatError(
                f"unknown format {format!r} (known: {', '.join(s.name for s in formats())})",
                location=SourceLocation(str(path)),
            ) from None
    seen = peek(load_source(path))
    for spec in formats():
        if _safe_sniff(spec, seen):
            return spec
    for spec in formats():
        if seen.suffix in spec.extensions:
            return spec
    raise UnknownFormatError(
        f"no reader accepts this file (tried: {', '.join(s.name for s in formats())})",
        location=SourceLocation(str(path)),
        hint="name the format with --format",
    )


#: Files kept beside reports that are never reports: process models, notes, scripts, the
#: history store and its journals, pictures, the logs ``setupfix diagnose`` reads beside
#: a series, the hidden truth ``setupfix simulate`` writes beside one, and a folder's read-me.
#: Folder listings (:mod:`parsers.folders`) leave them out.
NOT_REPORT_SUFFIXES: tuple[str, ...] = (
    ".toml",
    ".md",
    ".py",
    ".pyc",
    ".db",
    ".db-wal",
    ".db-shm",
    ".db-journal",
    ".sqlite",
    ".svg",
    ".png",
)
NOT_REPORT_NAMES: tuple[str, ...] = ("corrections.csv", "temperatures.csv", "truth.json", "readme.txt")


def never_a_report(name: str) -> bool:
    """True for a file name that is never a report (:data:`NOT_REPORT_SUFFIXES`, :data:`NOT_REPORT_NAMES`)."""
    folded = name.lower()
    return folded.endswith(NOT_REPORT_SUFFIXES) or folded in NOT_REPORT_NAMES


def check_options(spec: FormatSpec, options: dict[str, Any], where: str) -> None:
    """Refuse an option the reader does not use (rather than ignore it silently).

    Raises
    ------
    ParameterError
        Naming the option, the reader and the options it takes.
    """
    unused = [k for k, v in options.items() if v is not None and k not in spec.options]
    if unused:
        takes = ", ".join(f"--{o}" for o in spec.options) or "no options"
        raise ParameterError(
            f"the {spec.name} reader does not use --{unused[0]} (it takes {takes})",
            location=SourceLocation(where),
        )


def read_report(path: str | Path | Source, *, format: str | None = None, **options: Any) -> ReadResult:
    """Read one report (``-``: standard input) into the canonical table, with the reader's notes.

    The input is read once (within the size limit), sniffed from those bytes and read
    from them.

    Parameters
    ----------
    path : str, Path or Source
        The report; ``-`` reads standard input.
    format : str, optional
        Registry name; chosen by content, then extension, when omitted.  A column
        mapping (``columns=``) without a format means the ``table`` reader.
    **options
        ``unit``, ``encoding``, ``columns``, ``lenient`` (None/False = not given).  One
        the chosen reader does not use is refused, except ``lenient``: it only allows
        skipping a self-contradicting row, so a reader that never skips one ignores it
        (``batch --lenient`` over a folder of mixed formats).

    Returns
    -------
    ReadResult

    Raises
    ------
    ParseError
        (or its :class:`UnknownFormatError`) naming the file and place.
    ParameterError
        For an option the reader does not use, or an unknown option.
    """
    unknown = [k for k in options if k not in OPTIONS]
    if unknown:
        raise ParameterError(f"read_report: unknown option {unknown[0]!r} (known: {', '.join(OPTIONS)})")
    if not format and options.get("columns") and "table" in _REGISTRY:
        format = "table"
    source = load_source(path)
    if not source.data.removeprefix(b"\xef\xbb\xbf").strip(b" \t\r\n\x00"):
        raise ParseError("empty file", location=SourceLocation(source.name))
    spec = find_format(source, format)
    options = {k: v for k, v in options.items() if v is not None and v is not False}
    if "lenient" not in spec.options:  # only relaxes: a reader that never skips a row has nothing to relax
        options.pop("lenient", None)
    check_options(spec, options, source.name)
    missing = spec.complete(source.data) if spec.complete and source.data.strip() else None
    try:
        with collecting() as notes:
            table = spec.read(source, **options)
        if missing == NO_FINAL_LINE_BREAK and not _last_line_holds_no_data(spec, source, options, table):
            raise _truncated(spec, source, missing)
    except SetupfixError as exc:
        exc.message = visible_name(exc.message)  # a message quoting the file's bytes stays one printable line
        if missing and exc.message.startswith(missing):
            raise
        if missing:
            raise ParseError(
                f"{exc.message}; and the file {missing}, so it may be truncated",
                location=exc.location,
                hint="read it again once it is complete",
            ) from None
        raise
    if missing and missing != NO_FINAL_LINE_BREAK:
        raise _truncated(spec, source, missing)
    return ReadResult(table, (*notes, *verdict_notes(table, source.name)), spec.name, source.name)


def _truncated(spec: FormatSpec, source: Source, missing: str) -> ParseError:
    return ParseError(
        f"{missing}: the {spec.name} file may be truncated (still being written, or an interrupted copy)",
        location=SourceLocation(source.name),
        hint="read it again once it is complete",
    )


def _last_line_holds_no_data(spec: FormatSpec, source: Source, options: dict[str, Any], table: pd.DataFrame) -> bool:
    """True when the file read without its unterminated last line gives the same rows.

    Some real writers leave the last line unterminated (a Q-DAS ``K0081`` field, an OGP
    rule of dashes); that is harmless when the line carries no number of a row.
    """
    cut = max(source.data.rfind(b"\n"), source.data.rfind(b"\r"))
    if cut < 0:
        return False
    try:
        with collecting():
            shorter = spec.read(Source(source.name, source.data[: cut + 1], source.file), **options)
    except SetupfixError:
        return False
    return row_keys(shorter) == row_keys(table)


def read(path: str | Path, *, format: str | None = None, **options: Any) -> pd.DataFrame:
    """Read one report into the canonical table (the table of :func:`read_report`).

    Kept for callers written before :func:`read_report`: the notes are re-issued as
    :class:`~setupfix.core.errors.ParseWarning` so that they are not lost.  New code uses
    :func:`read_report` and its ``notes``, which never touch the process-global
    :mod:`warnings` state.

    Raises
    ------
    ParseError, ParameterError
        As :func:`read_report`.
    """
    result = read_report(path, format=format, **options)
    for item in result.notes:
        where = f"{item.location}: " if item.location else ""
        warnings.warn(f"{where}{item.message}", ParseWarning, stacklevel=2)
    return result.table
