"""Export glue: the controller formats the screen offers, the text it shows and the write.

The text shown is :func:`setupfix.usecases.export.offsets_text` and the write is
:func:`setupfix.usecases.export.export` of the same cycles
(:func:`setupfix.tui.session.export_cycles`): what the confirmation screen displays
is byte for byte what lands in the file, and what ``setupfix correct --offsets`` writes
(the thermal feed-forward included).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import PurePath

from setupfix.core.errors import ExportError
from setupfix.outputs.controllers import CONTROLLERS as _REGISTRY
from setupfix.outputs.controllers import PROGRAM_SUFFIX
from setupfix.outputs.writers import check_target
from setupfix.tui.screens.export import ExportRequest
from setupfix.tui.session import OpenedReport, export_cycles
from setupfix.usecases.export import Exported, export, offsets_text

__all__ = ["CONTROLLERS", "SUFFIXES", "export_name", "preview", "write_offsets"]

#: Controller formats offered, in menu order (the pipeline's registry).
CONTROLLERS: tuple[str, ...] = tuple(_REGISTRY)
#: File suffix by controller: a program's (:data:`~setupfix.outputs.controllers.PROGRAM_SUFFIX`), the CSV's.
SUFFIXES: dict[str, str] = {"csv": ".csv", **PROGRAM_SUFFIX}


def export_name(path: str, controller: str) -> str:
    """``path`` with the suffix of ``controller`` (``offsets.csv`` → ``offsets.nc`` for fanuc) when it ends in
    one of the export suffixes or has none; any other name is the operator's and is kept."""
    if not path.strip():
        return path
    name = PurePath(path).name
    stem, dot, suffix = name.rpartition(".")
    if dot and f".{suffix.lower()}" not in SUFFIXES.values():
        return path
    return path[: len(path) - len(name)] + (stem if dot else name) + SUFFIXES.get(controller, "")


def preview(opened: OpenedReport, cycle: int) -> Callable[[str], str]:
    """The text an export of ``opened`` writes in a controller's syntax (``cycle``: the one on screen)."""

    def text(controller: str) -> str:
        return offsets_text(export_cycles(opened, controller, cycle), controller, opened.current)

    return text


def write_offsets(request: ExportRequest, opened: OpenedReport, cycle: int) -> Exported:
    """Write what the operator confirmed, atomically (a file is complete or not there).

    Only a regular file (new or existing) is written; a folder, device, FIFO or link
    is refused with an :class:`~setupfix.core.errors.ExportError` naming it.  ``-`` (standard
    output) is refused too: the terminal belongs to the screen.
    """
    if request.path.strip() == "-":
        raise ExportError("standard output is the screen here: give a file name")
    check_target(request.path)
    # the same cycles through the same function as preview(): the text shown is the text written
    return export(
        export_cycles(opened, request.controller, cycle),
        request.path,
        controller=request.controller,
        current=opened.current,
    )
