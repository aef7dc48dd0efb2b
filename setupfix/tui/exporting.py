"""Export glue: the controller formats the screen offers, their text, the write.

The text comes from the pipeline's renderer and is written as shown: what the
confirmation screen displays is byte for byte what lands in the file.
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.atomic import atomic_write
from setupfix.errors import ExportError, SourceLocation
from setupfix.pipeline.correct import PartCorrection
from setupfix.pipeline.view import offsets_csv_text
from setupfix.tui.screens.export import ExportRequest

__all__ = ["CONTROLLERS", "render_offsets", "write_offsets"]

#: Controller formats offered, in menu order.
CONTROLLERS: tuple[str, ...] = ("csv",)


def render_offsets(corrections: Sequence[PartCorrection], controller: str) -> str:
    """The offsets of every cycle of the report in ``controller`` format."""
    if controller != "csv":
        raise ExportError(f"unknown controller format {controller!r} (known: {', '.join(CONTROLLERS)})")
    rows = [row for c in corrections for row in c.offsets()]
    return offsets_csv_text(rows, resolution=corrections[0].model.resolution)


def write_offsets(request: ExportRequest) -> None:
    """Write the confirmed text atomically (a file is complete or not there)."""
    try:
        with atomic_write(request.path) as stream:
            stream.write(request.text)
    except OSError as exc:
        raise ExportError(f"cannot write: {exc.strerror or exc}", location=SourceLocation(request.path)) from exc
