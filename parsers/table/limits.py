"""Bounds on an Excel workbook checked before any reader allocates for it (issue 10).

python-calamine allocates a dense grid up to the last cell a sheet names: a 5 KB
``.xlsx`` with one cell at ``XFD1048576`` asks for 512 GiB and aborts the process; a
cell at ``ZZ200000`` costs 19 s and 5.6 GB.  A zip bomb unpacks without limit.  So the
zip directory is checked first (total unpacked size, compression ratio), then every
worksheet is streamed once through :mod:`zipfile` (decompressing at most the declared
size, bounded) to find its ``<dimension>`` and the largest cell reference.  Written
here because neither calamine nor openpyxl exposes such limits.
"""

from __future__ import annotations

import io
import re
import zipfile

from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["check_workbook", "MAX_UNPACKED_BYTES", "MAX_CELLS", "MAX_RATIO"]

#: Largest total unpacked size of a workbook [bytes].
MAX_UNPACKED_BYTES = 512 * 2**20
#: Largest compression ratio of one member bigger than 1 MiB (real sheets compress ~10-30×).
MAX_RATIO = 200
#: Largest sheet area (rows × columns up to the last cell named) the grid reader may allocate.
MAX_CELLS = 5_000_000

_REF = re.compile(
    rb"<(?:c|row|dimension)\b[^>]*?\br(?:ef)?="
    rb'"\$?([A-Z]{0,3})\$?([0-9]{1,9})(?::\$?([A-Z]{0,3})\$?([0-9]{1,9}))?"'
)
_CHUNK = 1 << 20


def _column(letters: bytes) -> int:
    n = 0
    for ch in letters:
        n = n * 26 + (ch - 64)
    return n


def _area(member: zipfile.ZipInfo, zf: zipfile.ZipFile, name: str) -> tuple[int, int]:
    """(last row, last column) any cell, row or dimension of the sheet names."""
    rows = cols = 0
    tail = b""
    seen = 0
    with zf.open(member) as fh:
        while True:
            chunk = fh.read(_CHUNK)
            if not chunk:
                break
            seen += len(chunk)
            if seen > MAX_UNPACKED_BYTES:
                raise ParseError(
                    f"worksheet {member.filename} unpacks to over {MAX_UNPACKED_BYTES // 2**20} MiB",
                    location=SourceLocation(name),
                )
            data = tail + chunk
            for m in _REF.finditer(data):
                for letters, digits in ((m.group(1), m.group(2)), (m.group(3), m.group(4))):
                    if digits:
                        rows = max(rows, int(digits))
                        if letters:
                            cols = max(cols, _column(letters))
            tail = data[-256:]
    return rows, cols


def check_workbook(data: bytes, name: str) -> None:
    """Refuse a workbook whose unpacked size or sheet area is beyond the limits.

    Raises
    ------
    ParseError
        Naming the file and the member or sheet: not a zip, a zip bomb, or a sheet
        whose last cell spans more than :data:`MAX_CELLS` cells.
    """
    where = SourceLocation(name)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            members = zf.infolist()
            total = sum(m.file_size for m in members)
            if total > MAX_UNPACKED_BYTES:
                raise ParseError(
                    f"workbook unpacks to {total // 2**20} MiB (limit {MAX_UNPACKED_BYTES // 2**20} MiB)",
                    location=where,
                )
            for m in members:
                if m.file_size > 2**20 and m.file_size > MAX_RATIO * max(m.compress_size, 1):
                    raise ParseError(
                        f"{m.filename} is compressed {m.file_size // max(m.compress_size, 1)}:1: "
                        "a zip bomb, not a workbook",
                        location=where,
                    )
            for m in members:
                if m.filename.startswith("xl/worksheets/") and m.filename.endswith(".xml"):
                    rows, cols = _area(m, zf, name)
                    if rows * max(cols, 1) > MAX_CELLS:
                        raise ParseError(
                            f"sheet {m.filename.rsplit('/', 1)[-1]} spans {rows} rows x {cols} columns "
                            f"(limit {MAX_CELLS} cells): not a measurement table",
                            location=where,
                        )
    except ParseError:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError, ValueError, NotImplementedError) as exc:
        raise ParseError(f"not a readable Excel workbook: {exc}", location=where) from None
