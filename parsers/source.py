"""Opening a report: bytes, encoding sniffing, and the peek the sniffers look at."""

from __future__ import annotations

import codecs
import csv
import io
import os
import re
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from parsers import numbers
from parsers.names import visible_name
from setupfix.core.errors import ParseError, SourceLocation

__all__ = [
    "Peek",
    "Source",
    "check_encoding",
    "STDIN",
    "load_source",
    "peek",
    "peek_file",
    "decode",
    "read_bytes",
    "read_text",
    "parse_number",
    "point_number",
    "csv_records",
    "final_line_break",
    "end_statement",
]

#: Largest report accepted [bytes]; a CMM text report is kilobytes, a JSON export megabytes.
MAX_REPORT_BYTES = 256 * 1024 * 1024

#: Bytes a sniffer sees: enough for any header we recognise, small enough to be cheap.
PEEK_BYTES = 8192


@dataclass(frozen=True)
class Peek:
    """What a sniffer sees of a file: its path, first bytes and their decoded text."""

    path: Path
    head: bytes
    text: str

    @property
    def suffix(self) -> str:
        return self.path.suffix.lower()


#: Codecs Python accepts as text encodings that rewrite text instead of mapping bytes to characters.
_TRANSFORMS = frozenset({"idna", "punycode", "unicode-escape", "raw-unicode-escape", "undefined", "utf-7"})
_PROBE = "0123456789.,-+eE abcXYZ_;:/()\t\r\n"


def check_encoding(encoding: str, where: str = "") -> str:
    """The codec name of ``encoding`` if it is a character set a report can be written in.

    Refused: unknown names, byte transforms (``hex``, ``base64``), and text codecs that
    rewrite text (``punycode``, ``idna``, ``unicode_escape``, ``utf-7``); the character set
    must map digits, signs and separators to themselves (ASCII-compatible, or UTF-16/32).

    Raises
    ------
    ParseError
        Naming the encoding (and ``where``, the file, when given).
    """
    location = SourceLocation(where) if where else None
    try:
        info = codecs.lookup(encoding)
    except LookupError:
        raise ParseError(f"unknown encoding {encoding!r}", location=location) from None
    usable = getattr(info, "_is_text_encoding", True) and info.name not in _TRANSFORMS
    if usable and not info.name.startswith(("utf-16", "utf-32")):
        try:
            usable = (
                _PROBE.encode(info.name).decode(info.name) == _PROBE
                and _PROBE.encode("ascii").decode(info.name) == _PROBE
            )
        except (UnicodeError, ValueError):
            usable = False
    if not usable:
        raise ParseError(
            f"encoding {encoding!r} is not a character set a report is written in (e.g. utf-8, cp1252, cp949, utf-16)",
            location=location,
        )
    return info.name


def decode(data: bytes, path: str, encoding: str | None = None) -> str:
    """Decode report bytes: the given encoding, else UTF-8 (BOM or not), UTF-16 by BOM,
    CP949 when the bytes form valid Korean double-byte text, else CP1252.

    CP1252 is the last resort because every byte sequence is almost valid in it; it
    is what Western-European Windows CMM software writes (CALYPSO, PC-DMIS).

    Raises
    ------
    ParseError
        If an explicitly given encoding is unknown or does not fit the bytes.
    """
    if encoding:
        try:
            return data.decode(check_encoding(encoding, path))
        except UnicodeDecodeError as exc:
            line = data[: exc.start].count(b"\n") + 1
            raise ParseError(f"bytes are not {encoding} text", location=SourceLocation(path, line=line)) from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        pass
    try:
        text = data.decode("cp949")
        # Korean text rather than Western bytes that happen to pair up: most non-ASCII
        # characters are Hangul syllables (a CP1252 "ä" + "n" decodes to one Hanja, not Hangul).
        wide = [ch for ch in text if ord(ch) > 127]
        if wide and sum("\uac00" <= ch <= "\ud7a3" for ch in wide) >= 0.5 * len(wide):
            return text
    except UnicodeDecodeError:
        pass
    return data.decode("cp1252", errors="replace")


@dataclass(frozen=True)
class Source:
    """One input, read once into memory: its name as given (``-`` for stdin) and its bytes.

    Every reader takes a :class:`Source` (or a path, read here into one); the sniffers
    and the reader see the same bytes, so a pipe (``/dev/stdin``, ``<(…)``) is read in
    full once and nothing is lost to a second open.  ``name`` is printable
    (:func:`parsers.names.visible_name` of the path); ``file`` is the path as opened,
    for files read beside it (a QIF plan, a PiWeb characteristics file).
    """

    name: str
    data: bytes
    file: str = ""

    def __str__(self) -> str:
        return self.name

    @property
    def path(self) -> Path:
        """The path the bytes were read from (meaningless for stdin)."""
        return Path(self.file or self.name)

    @property
    def is_stdin(self) -> bool:
        return self.name == STDIN


#: The name that means standard input.
STDIN = "-"


def _read_limited(stream: BinaryIO, name: str) -> bytes:
    data = stream.read(MAX_REPORT_BYTES + 1)
    if len(data) > MAX_REPORT_BYTES:
        raise ParseError(f"larger than {MAX_REPORT_BYTES // 2**20} MiB: not a report", location=SourceLocation(name))
    return data


def load_source(path: str | Path | Source) -> Source:
    """Read a report once, within :data:`MAX_REPORT_BYTES` (``-``: standard input).

    This is the one place a report's bytes are read; every reader goes through it.

    Raises
    ------
    ParseError
        If the file cannot be read (named with the OS reason), is a folder, or is larger
        than :data:`MAX_REPORT_BYTES`.
    """
    if isinstance(path, Source):
        return path
    name = os.fspath(path)
    if name == STDIN:
        return Source(name, _read_limited(sys.stdin.buffer, "<stdin>"))
    try:
        with open(path, "rb") as fh:
            data = _read_limited(fh, visible_name(name))
    except IsADirectoryError:
        raise ParseError("is a folder, not a report", location=SourceLocation(visible_name(name))) from None
    except OSError as exc:
        raise ParseError(f"cannot read: {exc.strerror or exc}", location=SourceLocation(visible_name(name))) from None
    return Source(visible_name(name), data, name)


def read_bytes(path: str | Path | Source) -> bytes:
    """All bytes of a report (see :func:`load_source`).

    Raises
    ------
    ParseError
        If the file cannot be read or is larger than :data:`MAX_REPORT_BYTES`.
    """
    return load_source(path).data


def read_text(path: str | Path | Source, encoding: str | None = None) -> str:
    """Read and :func:`decode` a text report."""
    return decode(read_bytes(path), str(path), encoding)


def parse_number(text: str) -> float:
    """A number with a decimal point or a single decimal comma (``44,158745``).

    Raises
    ------
    ValueError
        (a :class:`ParseError`) If the text is not a finite number.
    """
    return numbers.parse_number(text, decimal="auto")


def point_number(text: str, where: SourceLocation, what: str = "", *, allow_empty: bool = True) -> float:
    """A finite number written with a decimal point, as the canonical CSV and DMIS require.

    Empty text gives NaN when ``allow_empty``.  No decimal comma: a comma separates fields.

    Raises
    ------
    ParseError
        At ``where``, naming ``what``, when the text is not a finite number.
    """
    return numbers.parse_number(text, location=where, what=what.rstrip(": "), allow_empty=allow_empty)


def final_line_break(data: bytes) -> str | None:
    """None when ``data`` ends with a line break (trailing NULs, e.g. of UTF-16, aside), else why not.

    Every text-report writer seen ends its last line; a file that does not was most
    likely cut short (read while still being written, an interrupted copy).
    """
    if data.rstrip(b"\x00")[-1:] in (b"\n", b"\r"):
        return None
    return NO_FINAL_LINE_BREAK


#: The reason :func:`final_line_break` gives.
NO_FINAL_LINE_BREAK = "does not end with a line break"


def end_statement(word: str) -> Callable[[bytes], str | None]:
    """A completeness check: the last non-blank line is ``word`` (``ENDFIL``, ``END``), case-insensitive."""
    pattern = re.compile(rb"(?:^|[\r\n])[ \t]*" + re.escape(word.encode()) + rb"[ \t]*[\r\n\x00\x1a]*\Z", re.IGNORECASE)

    def check(data: bytes) -> str | None:
        return None if pattern.search(data.rstrip(b"\x00")) else f"does not end with its {word} line"

    return check


def csv_records(text: str, path: str, **fmtparams: object) -> Iterator[tuple[int, list[str]]]:
    """Records of delimited text with the line each ends on (stdlib :mod:`csv`).

    Raises
    ------
    ParseError
        Where the csv module gives up (a NUL byte, a stray carriage return inside an
        unquoted field, a runaway quote), with the line.
    """
    reader = csv.reader(io.StringIO(text, newline=""), **fmtparams)  # type: ignore[arg-type]  # csv dialect keywords, passed through
    while True:
        try:
            record = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise ParseError(
                f"unreadable line: {exc}", location=SourceLocation(path, line=reader.line_num + 1)
            ) from None
        yield reader.line_num, record


def peek(source: Source) -> Peek:
    """What the sniffers see of ``source``: its first :data:`PEEK_BYTES` bytes, decoded."""
    head = source.data[:PEEK_BYTES]
    try:
        text = head.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        # A multi-byte character may be cut at PEEK_BYTES; decode what is whole.
        text = (
            head[: exc.start].decode("utf-8-sig", errors="replace")
            if exc.start > PEEK_BYTES - 4
            else head.decode("cp1252", errors="replace")
        )
    return Peek(path=source.path, head=head, text=text)


def peek_file(path: str | Path | Source) -> Peek:
    """Read ``path`` (once, see :func:`load_source`) and :func:`peek` at it.

    Raises
    ------
    ParseError
        If the file cannot be read.
    """
    return peek(load_source(path))
