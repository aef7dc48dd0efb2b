"""The hostile-input corpus (issue 10): one report file per case, generated here, never committed.

Each :class:`Case` names a file and how to make its bytes; ``expect`` is a regular
expression the one-line refusal must contain.  Every command that reads reports
runs the whole corpus in ``test_corpus.py``: exit status 1 (or 2 for a bad option),
one ``error:`` line naming the file, never exit 3 / "internal error" / a traceback.

To add a case, append a :class:`Case` to :data:`CASES` (other slices: your cases too).
:data:`HOSTILE_NAMES` are file names no command may choke on (formula starts, tab, CR,
line feed, bytes that are not UTF-8); each names a refused file in :data:`CASES` too, and
``test_names.py`` runs good reports under them through every command.  ``test_readers.py``
runs every case through every reader of the registry; ``test_folders.py`` runs a whole
corpus folder (with links, loops and an unreadable sub-folder) through ``batch``.
``python -m tests.hostile.cases DIR`` writes the corpus into DIR to try by hand.
"""

from __future__ import annotations

import io
import os
import sys
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"


@dataclass(frozen=True)
class Case:
    """One hostile input: file name, a maker of its bytes, the refusal expected, extra options."""

    name: str
    make: Callable[[], bytes]
    expect: str
    options: tuple[str, ...] = field(default=())


def _canonical(rows: str) -> bytes:
    return ("characteristic,nominal,actual,lower,upper,part\n" + rows).encode()


def _cut(path: Path, size: int) -> Callable[[], bytes]:
    return lambda: path.read_bytes()[:size]


def _edit(path: Path, old: bytes, new: bytes) -> Callable[[], bytes]:
    return lambda: path.read_bytes().replace(old, new, 1)


def _xlsx(ref: str) -> bytes:
    import openpyxl

    book = openpyxl.Workbook()
    sheet = book.active
    for col, head in zip("ABC", ("characteristic", "nominal", "actual"), strict=True):
        sheet[f"{col}1"] = head
    sheet[ref] = 1
    buffer = io.BytesIO()
    book.save(buffer)
    return buffer.getvalue()


def _zip_bomb() -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("[Content_Types].xml", "<Types/>")
        zf.writestr("xl/worksheets/sheet1.xml", b"<worksheet>" + b" " * (4 * 2**20) + b"</worksheet>")
    return buffer.getvalue()


def _qif(body: str, encoding: str = "utf-8", doctype: str = "") -> bytes:
    text = (
        f'<?xml version="1.0" encoding="{encoding.upper()}"?>\n{doctype}'
        f'<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">{body}</QIFDocument>\n'
    )
    return text.encode(encoding)


_DTD = '<!DOCTYPE QIFDocument [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
_EXTERNAL = (
    '<ExternalQIFReferences><ExternalQIFDocument id="9"><URI>{uri}</URI></ExternalQIFDocument>'
    '</ExternalQIFReferences><Results><MeasurementResultsSet><MeasurementResults id="1">'
    "<MeasuredCharacteristics><CharacteristicMeasurements>"
    '<DiameterCharacteristicMeasurement id="2"><CharacteristicItemId xId="5">9</CharacteristicItemId>'
    "<Value>1</Value></DiameterCharacteristicMeasurement></CharacteristicMeasurements>"
    "</MeasuredCharacteristics></MeasurementResults></MeasurementResultsSet></Results>"
)

CASES: list[Case] = [
    Case("truncated_cycle.csv", _cut(GUIDE / "cycle_01.csv", 322), "may be truncated"),
    Case("truncated_cycle.dmo", _cut(GUIDE / "cycle_01.dmo", 4000), "may be truncated"),
    Case("truncated_cycle.qif", _cut(GUIDE / "cycle_01.qif", 20000), "not well-formed XML"),
    Case(
        "underscore.csv", lambda: _canonical("P1 D1,25,-0_0309,-0.1,0.1,cycle\n"), "expected a number, found '-0_0309'"
    ),
    Case("nan_limit.csv", lambda: _canonical("P1 D1,25,24.97,-0.1,NaN,cycle\n"), "expected a number, found 'NaN'"),
    Case("inf_actual.csv", lambda: _canonical("P1 D1,25,inf,-0.1,0.1,cycle\n"), "expected a number, found 'inf'"),
    Case("huge_actual.csv", lambda: _canonical("P1 D1,25,1e308,-0.1,0.1,cycle\n"), "beyond any measurable length"),
    Case("digits401.csv", lambda: _canonical(f"P1 D1,{'9' * 401},25,-0.1,0.1,cycle\n"), "expected a number"),
    Case("hex.csv", lambda: _canonical("P1 D1,0x19,25,-0.1,0.1,cycle\n"), "expected a number, found '0x19'"),
    Case(
        "inch_overflow.dmo",
        lambda: (
            b"UNITS/INCH,ANGDEC\nF(P)=FEAT/POINT,CART,1e307,0,0,0,0,1\n"
            b"T(P_X)=TOL/CORTOL,XAXIS,-0.1,0.1\nFA(P)=FEAT/POINT,CART,1e307,0,0,0,0,1\n"
            b"TA(P_X)=TOL/CORTOL,XAXIS,0,INTOL\nENDFIL\n"
        ),
        "beyond",
    ),
    Case(
        "qif_underscore.qif",
        _edit(GUIDE / "cycle_01.qif", b"<Value>24.9691</Value>", b"<Value>24_9691</Value>"),
        "Value.*expected a number, found '24_9691'",
    ),
    Case(
        "qif_nan_limit.qif",
        _edit(GUIDE / "cycle_01.qif", b"<MaxValue>0.1</MaxValue>", b"<MaxValue>NaN</MaxValue>"),
        "MaxValue.*expected a number, found 'NaN'",
    ),
    Case("dtd_utf16be.qif", lambda: _qif("", "utf-16-be", _DTD), "document type or entity declarations"),
    Case("dtd_utf32.qif", lambda: _qif("", "utf-32", _DTD), "document type or entity declarations"),
    Case("plan_passwd.qif", lambda: _qif(_EXTERNAL.format(uri="file:///etc/passwd")), "not beside the file"),
    Case("plan_proc.qif", lambda: _qif(_EXTERNAL.format(uri="/proc/self/environ")), "not beside the file"),
    Case("plan_escape.qif", lambda: _qif(_EXTERNAL.format(uri="../elsewhere/plan.qif")), "not beside the file"),
    Case("cell_XFD1048576.xlsx", lambda: _xlsx("XFD1048576"), "spans 1048576 rows x 16384 columns"),
    Case("cell_ZZ200000.xlsx", lambda: _xlsx("ZZ200000"), "spans 200000 rows"),
    Case("zip_bomb.xlsx", _zip_bomb, "zip bomb"),
    Case("punycode.csv", lambda: _canonical("P1 D1,25,24.97,-0.1,0.1,cycle\n"), "punycode", ("--encoding", "punycode")),
    Case("empty.csv", lambda: b"", "empty file"),
    Case("blank.dmo", lambda: b"\r\n \n", "empty file"),
    Case("binary.dmo", lambda: bytes(range(256)) * 4, "ENDFIL|no tolerance|not|truncated"),
]


#: File names a command must show escaped, never choke on (and must not run as a spreadsheet formula).
HOSTILE_NAMES: tuple[str, ...] = (
    "=HYPERLINK(0).csv",
    "+sum.csv",
    "-minus.csv",
    "@at.csv",
    "\ttab.csv",
    "\rcr_first.csv",
    "cr\rinside.csv",
    "line\nfeed.csv",
    os.fsdecode(b"not_utf8_\xff\xfe.csv"),
)

CASES += [
    Case("decimal_comma.csv", lambda: _canonical("P1 D1,25,24,9691,-0.1,0.1,cycle\n"), "7 fields, header has 6"),
    Case(
        "decimal_comma_quoted.csv",
        lambda: _canonical('P1 D1,25,"24,9691",-0.1,0.1,cycle\n'),
        "expected a number, found '24,9691'",
    ),
    Case("huge_1e300.csv", lambda: _canonical("P1 D1,25,1e300,-0.1,0.1,cycle\n"), "beyond any measurable length"),
    Case("binary.csv", lambda: bytes(range(256)) * 8, "no reader accepts|not|empty"),
    Case("nul_only.csv", lambda: b"\x00" * 64, "empty file"),
    *(Case(name, _cut(GUIDE / "cycle_01.csv", 322), "may be truncated") for name in HOSTILE_NAMES),
]


def write_corpus(folder: Path) -> list[tuple[Case, Path]]:
    """Write every case into ``folder``; returns (case, path) pairs."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for case in CASES:
        path = folder / case.name
        path.write_bytes(case.make())
        written.append((case, path))
    return written


if __name__ == "__main__":
    for _, p in write_corpus(Path(sys.argv[1] if len(sys.argv) > 1 else "hostile")):
        print(p)
