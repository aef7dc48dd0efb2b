"""Controller offset formats: the same offset rows in each controller's own syntax.

``render(name, rows, title=…) -> str`` for ``csv`` (the offsets CSV of
``../shared/spec/cli-json.md`` plus unit and mode), ``fanuc`` and ``haas`` (G10
programs), ``fanuc-macro`` and ``haas-macro`` (the offsets' macro variables),
``siemens`` (840D part program with system variables) and
``heidenhain`` (preset and tool table values).  Every renderer raises
:class:`~setupfix.core.errors.ExportError` naming a register it cannot express, so no
file is written half right.  :func:`parsers.current.read_current` reads the controller's current
offsets (``register,value``; ``register,axis,value`` in a multi-axis model) that turn *add*
rows into absolute *set* rows.  In a multi-axis model the rows are register components
(:mod:`setupfix.correction.offsets`); the renderers group them by register, so one block or table row
holds every axis of a WKS.

Program numbers: a program is named by ``program_number`` where its format has a name
(:data:`~setupfix.outputs.controllers.common.PROGRAM_NUMBERS`: the Fanuc/Haas ``O`` word,
the Siemens program name; the HEIDENHAIN tables and the CSV have none).  Without one the
renderers write ``O4501`` (Fanuc/Haas) and no Siemens name; the doors always give one:
``--program-number N``, else :func:`derived_program_number` of the correction's report and
part (``correct``, the TUI) — the same report and part always get the same number, others
one of :data:`DERIVED_PROGRAMS` (O1000…O7999: below the O8000/O9000 ranges a Fanuc control
may keep edit-protected, above the low numbers a shop numbers its own programs with) — and
in ``batch`` distinct numbers per program of a run
(:class:`~setupfix.outputs.batch_output.ProgramsOut`).

``batch --controller`` writes one program per cycle into a folder; :func:`program_path`
names it after the report's path below the batch folder (unique by construction:
``line_A/cycle.csv`` and ``line_B/cycle.csv``, ``cycle.csv`` and ``cycle.dmo`` never
share a program), shortened deterministically when a name exceeds :data:`NAME_MAX`.
"""

from __future__ import annotations

import hashlib
import importlib
import os
from collections.abc import Sequence
from pathlib import PurePosixPath
from typing import Protocol

from setupfix.core.errors import ParameterError
from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.controllers.common import PROGRAM_NUMBERS, check_program_number, check_values

__all__ = [
    "CONTROLLERS",
    "render",
    "renderer",
    "Renderer",
    "write_offsets",
    "PROGRAM_SUFFIX",
    "NAME_MAX",
    "PROGRAM_NAME_MAX",
    "program_path",
    "fit_name",
    "PROGRAM_NUMBERS",
    "DERIVED_PROGRAMS",
    "check_program_number",
    "derived_program_number",
    "program_title",
]


class Renderer(Protocol):
    """A controller format: the rows' text, ``title`` in a comment, ``program_number`` its name where it has one,
    ``spindle`` the axis a WKS rotation turns about."""

    def __call__(
        self, rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
    ) -> str: ...


#: Registry: controller name → "module:function" (imported on use).
CONTROLLERS: dict[str, str] = {
    "csv": "setupfix.outputs.controllers.csv_offsets:render",
    "fanuc": "setupfix.outputs.controllers.gcode:render_fanuc",
    "haas": "setupfix.outputs.controllers.gcode:render_haas",
    "siemens": "setupfix.outputs.controllers.siemens:render",
    "heidenhain": "setupfix.outputs.controllers.heidenhain:render",
    "fanuc-macro": "setupfix.outputs.controllers.fanuc_macro:render_fanuc_macro",
    "haas-macro": "setupfix.outputs.controllers.fanuc_macro:render_haas_macro",
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
        raise ParameterError(f"--controller: unknown controller {name!r} (known: {', '.join(CONTROLLERS)})") from None
    fn: Renderer = getattr(importlib.import_module(module), func)
    return fn


def render(
    name: str, rows: Sequence[OffsetRow], title: str = "", *, program_number: int | None = None, spindle: str = "Z"
) -> str:
    """Text of ``rows`` in controller format ``name``; ``title`` goes in a comment where the format has one,
    ``program_number`` names the program where the format has a name (see the module text).

    Raises
    ------
    ExportError
        A register (or a rotation) the format cannot express, a slot the control does not have, a value
        no control holds (:func:`~setupfix.outputs.controllers.common.check_values`: the bound of the
        current-offsets reader), or a program number the format cannot hold.
    """
    fn = renderer(name)
    check_values(name, rows)
    return fn(rows, title, program_number=program_number, spindle=spindle)


def write_offsets(
    rows: Sequence[OffsetRow],
    target: str,
    *,
    controller: str = "csv",
    title: str = "",
    program_number: int | None = None,
    spindle: str = "Z",
) -> None:
    """Render ``rows`` and write them atomically to ``target`` (``-``: standard output).

    The text is complete before the file is opened: a register the format cannot
    express leaves no file at all.
    """
    from setupfix.outputs.writers import write_text

    write_text(target, render(controller, rows, title, program_number=program_number, spindle=spindle))


def program_title(report: str, part: str) -> str:
    """A program's title comment: the report and the part, on one line whatever the names hold."""
    from parsers.names import visible_name

    return visible_name(f"{report} {part}".strip())


#: The numbers :func:`derived_program_number` chooses from (inclusive).
DERIVED_PROGRAMS = (1000, 7999)


def derived_program_number(*keys: str) -> int:
    """A program number in :data:`DERIVED_PROGRAMS` from ``keys`` (report, part): the same keys give the same
    number, different keys one of 7,000 numbers by a hash (SHA-256), so that two corrections rarely share one."""
    low, high = DERIVED_PROGRAMS
    digest = hashlib.sha256(os.fsencode("\0".join(keys))).digest()
    return low + int.from_bytes(digest[:8], "big") % (high - low + 1)


#: File suffix of a program by controller (every format but ``csv``).
PROGRAM_SUFFIX: dict[str, str] = {
    "fanuc": ".nc",
    "haas": ".nc",
    "siemens": ".mpf",
    "heidenhain": ".txt",
    "fanuc-macro": ".nc",
    "haas-macro": ".nc",
}

#: Longest file name [bytes] the file systems in use accept (POSIX ``NAME_MAX``).
NAME_MAX = 255
#: Longest program name [bytes]: room left for the atomic writer's temporary name beside it
#: (``.<name>.<pid>.<random>.tmp``, :mod:`setupfix.core.atomic`).
PROGRAM_NAME_MAX = NAME_MAX - 40


def _digest(text: str) -> str:
    return hashlib.sha256(os.fsencode(text)).hexdigest()[:10]


def fit_name(name: str, suffix: str = "", limit: int = NAME_MAX) -> str:
    """``name + suffix``, or when that exceeds ``limit`` bytes (file-system encoding) the longest
    prefix of ``name`` that fits with ``~`` and a 10-digit hash of the whole name before ``suffix``.

    Deterministic (the same name always gives the same file) and distinct for distinct names
    (up to the hash).
    """
    if len(os.fsencode(name + suffix)) <= limit:
        return name + suffix
    tail = f"~{_digest(name)}{suffix}"
    room = limit - len(os.fsencode(tail))
    head = name
    while len(os.fsencode(head)) > room:  # cut whole characters (an encoded character is never split)
        head = head[: max(0, min(len(head) - 1, room))]
    return head + tail


def program_path(report: str, part: str | None, controller: str) -> PurePosixPath:
    """Where ``batch`` writes the program of one cycle, relative to its output folder.

    Parameters
    ----------
    report : str
        The report's path relative to the batch folder, ``/``-separated (``line_A/cycle.csv``).
    part : str or None
        The cycle's part when the report holds several cycles (None: one cycle).
    controller : str
        A key of :data:`PROGRAM_SUFFIX`.

    Returns
    -------
    PurePosixPath
        The report's folders, then its full name (suffix kept, so ``cycle.csv`` and
        ``cycle.dmo`` differ), ``__<part>`` for one of several cycles (a part name with
        other characters than ASCII letters, digits, ``-_.`` has them as ``_`` and a
        hash of the name added: ``__P_1~3f…``), and the controller's suffix:
        ``line_A/cycle.csv.nc``, ``r.csv__P1.mpf``.  The file name fits in
        :data:`PROGRAM_NAME_MAX` bytes, each folder in :data:`NAME_MAX` (:func:`fit_name`).
    """
    rel = PurePosixPath(report)
    tag = ""
    if part is not None:
        plain = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in part)
        tag = "__" + plain + ("" if plain == part and plain else f"~{_digest(part)}")  # "P 1" ≠ "P_1"
    name = fit_name(rel.name + tag, PROGRAM_SUFFIX[controller], PROGRAM_NAME_MAX)
    folders = [fit_name(p) for p in rel.parts[:-1]]
    return PurePosixPath(*folders, name)
