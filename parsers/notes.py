"""Notes a reader leaves while reading (skipped rows, assumed units), returned as data.

A reader calls :func:`note`; :func:`parsers.read_report` collects the notes of that one
read into its :class:`~parsers.ReadResult`.  The collection lives in a
:class:`contextvars.ContextVar`, so reads in several threads (the TUI's workers, batch)
or asyncio tasks keep their notes apart; nothing goes through the process-global
:mod:`warnings` state.  Outside a collection a note is dropped.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from setupfix.core.errors import Note, SourceLocation

__all__ = ["note", "collecting"]

_CURRENT: ContextVar[list[Note] | None] = ContextVar("parsers_notes", default=None)


def note(message: str, location: SourceLocation | None = None, kind: str = "parse") -> None:
    """Record a note for the read in progress (dropped when none is collecting)."""
    notes = _CURRENT.get()
    if notes is not None:
        notes.append(Note(message, location, kind))


@contextmanager
def collecting() -> Iterator[list[Note]]:
    """Collect the notes recorded inside the block into the yielded list."""
    notes: list[Note] = []
    token = _CURRENT.set(notes)
    try:
        yield notes
    finally:
        _CURRENT.reset(token)
