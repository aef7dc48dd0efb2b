"""Controller offset formats: the same offset rows in each controller's own syntax.

``render(name, rows, title=…) -> str`` for ``csv`` (the offsets CSV of
``../shared/spec/cli-json.md`` plus unit and mode), ``fanuc`` and ``haas`` (G10
programs), ``siemens`` (840D part program with system variables) and
``heidenhain`` (preset and tool table values).  Every renderer raises
:class:`~setupfix.errors.ExportError` naming a register it cannot express, so no
file is written half right.  :func:`parsers.current.read_current` reads the controller's current
offsets (``register,value``) that turn *add* rows into absolute *set* rows.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence

from setupfix.errors import ParameterError
from setupfix.offsets import OffsetRow

__all__ = ["CONTROLLERS", "render", "renderer", "Renderer", "write_offsets"]

Renderer = Callable[[Sequence[OffsetRow], str], str]

#: Registry: controller name → "module:function" (imported on use).
CONTROLLERS: dict[str, str] = {
    "csv": "setupfix.pipeline.controllers.csv_offsets:render",
    "fanuc": "setupfix.pipeline.controllers.gcode:render_fanuc",
    "haas": "setupfix.pipeline.controllers.gcode:render_haas",
    "siemens": "setupfix.pipeline.controllers.siemens:render",
    "heidenhain": "setupfix.pipeline.controllers.heidenhain:render",
}


def renderer(name: str) -> Renderer:
    """The render function registered as ``name``.

    Raises
    ------
    ParameterError
        If no controller format has that name.
    """
    try:
        module, func = CONTROLLERS[name].split(":")
    except KeyError:
        raise ParameterError(f"--controller: unknown controller {name!r} "
                             f"(known: {', '.join(CONTROLLERS)})") from None
    fn: Renderer = getattr(importlib.import_module(module), func)
    return fn


def render(name: str, rows: Sequence[OffsetRow], title: str = "") -> str:
    """Text of ``rows`` in controller format ``name``; ``title`` goes in a comment where the format has one."""
    return renderer(name)(rows, title)


def write_offsets(rows: Sequence[OffsetRow], target: str, *, controller: str = "csv", title: str = "") -> None:
    """Render ``rows`` and write them atomically to ``target`` (``-``: standard output).

    The text is complete before the file is opened: a register the format cannot
    express leaves no file at all.
    """
    from setupfix.pipeline.writers import write_text

    write_text(target, render(controller, rows, title))
