"""Use case "parse": many reports in any supported format → one canonical table.

Shared by ``setupfix parse`` and anything that needs reports read in bulk: each
file is read on its own, so one bad file is reported (with its place) while the
others are still read.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

import parsers
from setupfix.errors import ParseError, ParseWarning, SetupfixError, SourceLocation
from setupfix.model import CANONICAL_COLUMNS
from setupfix.pipeline.writers import FLOAT_FORMAT, write_canonical_csv

__all__ = ["ParsedReport", "ParseOutcome", "parse_reports", "write_canonical_csv", "OUTPUT_COLUMNS",
           "list_formats"]

#: Columns ``setupfix parse`` writes: the canonical ones, then the reference-only flag.
OUTPUT_COLUMNS: tuple[str, ...] = (*CANONICAL_COLUMNS, "reference")


@dataclass(frozen=True)
class ParsedReport:
    """One report read: its path, the reader used, its rows and the reader's warnings."""

    path: str
    format: str
    table: pd.DataFrame
    warnings: tuple[str, ...] = ()


@dataclass
class ParseOutcome:
    """All reports of one ``parse`` call: those read and those refused."""

    reports: list[ParsedReport] = field(default_factory=list)
    failures: list[SetupfixError] = field(default_factory=list)

    @property
    def table(self) -> pd.DataFrame:
        """Rows of every readable report, in input order, with :data:`OUTPUT_COLUMNS`."""
        frames = [r.table for r in self.reports]
        if not frames:
            return pd.DataFrame(columns=list(OUTPUT_COLUMNS))
        table = pd.concat(frames, ignore_index=True)
        if "reference" not in table:
            table["reference"] = False
        table["reference"] = table["reference"].fillna(False).astype(bool)
        return table[list(OUTPUT_COLUMNS)]


def parse_reports(paths: Sequence[str | Path], *, format: str | None = None, unit: str | None = None,
                  encoding: str | None = None, columns: str | Mapping[str, str] | None = None) -> ParseOutcome:
    """Read each report; collect the tables and, separately, the errors.

    Parameters
    ----------
    paths : sequence of str or Path
        Report files.
    format, unit, encoding, columns
        As for :func:`parsers.read`.

    Returns
    -------
    ParseOutcome
        Never raises for a bad report: its :class:`~setupfix.errors.SetupfixError`
        is in ``failures``.
    """
    outcome = ParseOutcome()
    options = {k: v for k, v in {"unit": unit, "encoding": encoding, "columns": columns}.items() if v is not None}
    for path in paths:
        name = str(path)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ParseWarning)
            try:
                if Path(name).is_dir():
                    raise ParseError("is a folder, not a report", location=SourceLocation(name))
                spec = parsers.find_format(name, format or ("table" if columns else None))
                table = spec.read(Path(name), **options)
            except SetupfixError as exc:
                outcome.failures.append(exc)
                continue
        notes = tuple(str(w.message) for w in caught if issubclass(w.category, ParseWarning))
        outcome.reports.append(ParsedReport(name, spec.name, table, notes))
    return outcome


def list_formats() -> list[dict[str, object]]:
    """Registered report formats in sniffing order: name, extensions, description."""
    return [{"name": s.name, "extensions": list(s.extensions), "description": s.description}
            for s in parsers.formats()]
