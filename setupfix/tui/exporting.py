"""Export glue: the controller formats the screen offers and the write.

The text comes from :func:`setupfix.pipeline.session.offsets_text` and is written as
shown: what the confirmation screen displays is byte for byte what lands in the file.
"""

from __future__ import annotations

from setupfix.errors import ExportError
from setupfix.pipeline.controllers import CONTROLLERS as _REGISTRY
from setupfix.pipeline.writers import check_target, write_text
from setupfix.tui.screens.export import ExportRequest

__all__ = ["CONTROLLERS", "write_offsets"]

#: Controller formats offered, in menu order (the pipeline's registry).
CONTROLLERS: tuple[str, ...] = tuple(_REGISTRY)


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
