"""Opening a report: bytes, encoding sniffing, and the peek the sniffers look at."""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from parsers import numbers
from setupfix.errors import ParseError, SourceLocation

__all__ = ["Peek", "peek_file", "decode", "read_bytes", "read_text", "parse_number", "point_number",
           "csv_records"]

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
            return data.decode(encoding)
        except LookupError:
            raise ParseError(f"unknown encoding {encoding!r}", location=SourceLocation(path)) from None
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


def read_bytes(path: str | Path) -> bytes:
    """All bytes of a report.

    Raises
    ------
    ParseError
        If the file cannot be read (named with the OS reason) or is larger than
        :data:`MAX_REPORT_BYTES`.
    """
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_REPORT_BYTES + 1)
    except OSError as exc:
        raise ParseError(f"cannot read: {exc.strerror or exc}", location=SourceLocation(str(path))) from None
    if len(data) > MAX_REPORT_BYTES:
        raise ParseError(f"larger than {MAX_REPORT_BYTES} bytes: not a report", location=SourceLocation(str(path)))
    return data


def read_text(path: str | Path, encoding: str | None = None) -> str:
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


def csv_records(text: str, path: str, **fmtparams: object) -> Iterator[tuple[int, list[str]]]:
    """Records of delimited text with the line each ends on (stdlib :mod:`csv`).

    Raises
    ------
    ParseError
        Where the csv module gives up (a NUL byte, a stray carriage return inside an
        unquoted field, a runaway quote), with the line.
    """
    reader = csv.reader(io.StringIO(text, newline=""), **fmtparams)  # type: ignore[arg-type]
    while True:
        try:
            record = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise ParseError(f"unreadable line: {exc}", location=SourceLocation(path, line=reader.line_num + 1)) \
                from None
        yield reader.line_num, record


def peek_file(path: Path) -> Peek:
    """Read the first bytes of ``path`` for sniffing.

    Raises
    ------
    ParseError
        If the file cannot be opened.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(PEEK_BYTES)
    except OSError as exc:
        raise ParseError(f"cannot read: {exc.strerror}", location=SourceLocation(str(path))) from None
    try:
        text = head.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        # A multi-byte character may be cut at PEEK_BYTES; decode what is whole.
        text = head[: exc.start].decode("utf-8-sig", errors="replace") if exc.start > PEEK_BYTES - 4 else \
            head.decode("cp1252", errors="replace")
    return Peek(path=path, head=head, text=text)
