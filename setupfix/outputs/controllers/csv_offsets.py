"""The offsets CSV (``../shared/spec/cli-json.md``): the spec's columns first, then offset, current, value, verdict."""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.writers import offsets_csv_text

__all__ = ["render"]


def render(rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z") -> str:
    """The CSV has no program: ``title`` and ``program_number`` are not written."""
    return offsets_csv_text(rows)
