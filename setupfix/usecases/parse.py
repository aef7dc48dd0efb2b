"""Use case "parse": many reports in any supported format → one canonical table.

Shared by ``setupfix parse`` and anything that needs reports read in bulk: each
file is read on its own, so one bad file is reported (with its place) while the
others are still read.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

import parsers
from parsers.axes import AXIS_COLUMN
from setupfix.core.errors import Note, ParseError, SetupfixError, SourceLocation, UnknownFormatError
from setupfix.inputs.cycles import ReadOptions
from setupfix.model import CANONICAL_COLUMNS
from setupfix.model.measurements import GEOMETRY_OUTPUT_COLUMNS
from setupfix.outputs.writers import FLOAT_FORMAT, write_canonical_csv  # noqa: F401 - re-exported

__all__ = ["ParsedReport", "ParseOutcome", "parse_reports", "write_canonical_csv", "OUTPUT_COLUMNS", "list_formats"]

#: Columns ``setupfix parse`` writes: the canonical ones, then the reference-only flag.
OUTPUT_COLUMNS: tuple[str, ...] = (*CANONICAL_COLUMNS, "reference")


@dataclass(frozen=True)
class ParsedReport:
    """One report read: its path, the reader used, its rows and the reader's notes."""

    path: str
    format: str
    table: pd.DataFrame
    notes: tuple[Note, ...] = ()

    @property
    def warnings(self) -> tuple[str, ...]:
        """The notes as one line each (``file:line: message``)."""
        return tuple(str(n) for n in self.notes)


@dataclass(frozen=True, eq=False)
class ParseOutcome:
    """All reports of one ``parse`` call: those read and those refused."""

    reports: tuple[ParsedReport, ...] = ()
    failures: tuple[SetupfixError, ...] = ()
    #: Files of a folder input that no reader recognises (left out, not failures).
    skipped: tuple[Note, ...] = ()
    #: What a folder listing could not list or look at (a link to a folder, an unreadable
    #: folder, a file renamed while listed): each named, for a warning.
    problems: tuple[Note, ...] = ()
    #: Number of inputs after folders were expanded.
    inputs: int = 0

    @property
    def table(self) -> pd.DataFrame:
        """Rows of every readable report, in input order, with :data:`OUTPUT_COLUMNS`, then ``axis``
        where a report states one (:mod:`parsers.axes`; "" for the rows of others), then the
        geometry and uncertainty columns any report states
        (:data:`~setupfix.model.measurements.GEOMETRY_OUTPUT_COLUMNS`, in that order; empty for
        the rows of others)."""
        frames = [r.table for r in self.reports]
        if not frames:
            return pd.DataFrame(columns=list(OUTPUT_COLUMNS))
        table = pd.concat(frames, ignore_index=True)
        if "reference" not in table:
            table["reference"] = False
        table["reference"] = table["reference"].fillna(False).astype(bool)
        extra = [c for c in GEOMETRY_OUTPUT_COLUMNS if c in table and _stated(table[c])]
        for col in extra:
            if table[col].dtype == object:
                table[col] = table[col].fillna("")
        if AXIS_COLUMN not in table:
            return table[[*OUTPUT_COLUMNS, *extra]]
        table[AXIS_COLUMN] = table[AXIS_COLUMN].fillna("")
        return table[[*OUTPUT_COLUMNS, AXIS_COLUMN, *extra]]


def _stated(column: pd.Series) -> bool:
    """Whether a report states anything in an optional column (a number, or non-empty text)."""
    if column.dtype == object:
        return bool(column.map(lambda v: (isinstance(v, str) and v != "") or (isinstance(v, float) and v == v)).any())
    return bool(column.notna().any())


def parse_reports(paths: Sequence[str | Path], read: ReadOptions | None = None) -> ParseOutcome:
    """Read each report; collect the tables and notes and, separately, the errors.

    Parameters
    ----------
    paths : sequence of str or Path
        Report files, folders or ``-`` (standard input).  A folder stands for its
        reports and those of its sub-folders, as :func:`parsers.expand_inputs` lists
        them (the policy every command shares); an empty folder is a failure naming it.
    read : ReadOptions, optional
        The reader's options (format, unit, encoding, columns, lenient), as for
        :func:`parsers.read_report`; default: every one sniffed, not lenient.

    Returns
    -------
    ParseOutcome
        Never raises for a bad report: its :class:`~setupfix.core.errors.SetupfixError`
        is in ``failures``.  Thread-safe: notes come back as data.
    """
    options = read if read is not None else ReadOptions()
    inputs = parsers.expand_inputs(paths)
    failures: list[SetupfixError] = [
        ParseError("folder holds no report file", location=SourceLocation(folder)) for folder in inputs.empty
    ]
    skipped: list[Note] = []
    reports: list[ParsedReport] = []
    for name, from_folder in inputs.files:
        try:
            result = parsers.read_report(name, **options.kwargs())
        except UnknownFormatError as exc:
            if from_folder and not options.format:
                skipped.append(Note("not a report of a known format; left out", exc.location, "skipped"))
            else:
                failures.append(exc)
            continue
        except SetupfixError as exc:
            failures.append(exc)
            continue
        reports.append(ParsedReport(name, result.format, result.table, result.notes))
    return ParseOutcome(tuple(reports), tuple(failures), tuple(skipped), tuple(inputs.notes()), len(inputs.files))


def list_formats() -> list[dict[str, object]]:
    """Registered report formats in sniffing order: name, extensions, description."""
    return [{"name": s.name, "extensions": list(s.extensions), "description": s.description} for s in parsers.formats()]
