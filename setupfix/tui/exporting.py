"""Export glue: the controller formats the screen offers, their text, the write.

The text comes from the pipeline's renderer and is written as shown: what the
confirmation screen displays is byte for byte what lands in the file.
"""

from __future__ import annotations

from collections.abc import Sequence

from setupfix.errors import ExportError
from setupfix.offsets import offsets_csv_text
from setupfix.pipeline.correct import PartCorrection
from setupfix.pipeline.writers import check_target, write_text
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
    """Write the confirmed text atomically (a file is complete or not there).

    Only a regular file (new or existing) is written; a folder, device, FIFO or link
    is refused with an :class:`~setupfix.errors.ExportError` naming it.  ``-`` (standard
    output) is refused too: the terminal belongs to the screen.
    """
    if request.path.strip() == "-":
        raise ExportError("standard output is the screen here: give a file name")
    check_target(request.path)
    write_text(request.path, request.text)
