"""Every hostile case through every reader of the registry (``--format NAME``): a table or one clear line.

A reader forced on a file that is not its format must refuse it with a
:class:`~setupfix.core.errors.SetupfixError` naming the file (printable, one line), never
another exception; what it does read is a canonical table.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import parsers
from hostile.cases import CASES, Case
from parsers.names import visible_name
from setupfix.core.errors import SetupfixError
from setupfix.model import CANONICAL_COLUMNS

READERS = [spec.name for spec in parsers.formats()]
OPTIONS = {"--encoding": "encoding", "--unit": "unit", "--columns": "columns"}


def options_of(case: Case) -> dict[str, str]:
    pairs = zip(case.options[::2], case.options[1::2], strict=True)
    return {OPTIONS[flag]: value for flag, value in pairs}


@pytest.mark.parametrize("case", CASES, ids=lambda c: visible_name(c.name))
def test_every_reader_reads_a_table_or_refuses_naming_the_file(case: Case, tmp_path: Path) -> None:
    path = tmp_path / case.name
    path.write_bytes(case.make())
    refused = 0
    for reader in READERS:
        try:
            result = parsers.read_report(path, format=reader, **options_of(case))
        except SetupfixError as exc:
            line = str(exc)
            assert "\n" not in line and line.isprintable(), (reader, line)
            assert visible_name(case.name) in line, (reader, line)
            refused += 1
        else:
            assert set(CANONICAL_COLUMNS) <= set(result.table.columns), reader
            assert all(str(v).isprintable() for v in result.table["report"].dropna()), reader
    assert refused >= len(READERS) - 1, f"{case.name}: read by {len(READERS) - refused} readers"


def test_the_registry_has_every_reader() -> None:
    assert len(READERS) >= 10 and "canonical" in READERS and "qif" in READERS
