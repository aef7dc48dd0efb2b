"""Export: the one place that decides what of a recommendation reaches the controller, and writes it.

Policy, the same for every door (``correct --offsets``, the TUI's export, batch):

* **apply** — each correctable register's change (setup correction plus the thermal
  feed-forward), one row per register, zero included;
* **hold** — the rows are written too, each setup change 0 (plus the feed-forward,
  which does not depend on the setup verdict) with ``verdict`` ``hold``: "leave the
  offsets as they are" is a complete instruction, and with ``current`` offsets the
  program sets every register to its present value (safe to run);
* **reject** — nothing is written: :func:`export` refuses with an
  :class:`~setupfix.core.errors.ExportError` naming the report and the part;
* a controller program (every format but ``csv``) holds one cycle: several are refused
  (choose one with ``--part``); a draft model (``[process] draft = true``) writes no program
  (:func:`check_program_model`), only the CSV's hold rows;
* a program is numbered ``program_number`` (``--program-number``) where its format has a
  name, else :func:`~setupfix.outputs.controllers.derived_program_number` of the cycle's
  report and part: the same correction always gets the same number, two corrections
  rarely one (see :mod:`setupfix.outputs.controllers`); a number the format cannot hold
  is refused.

The text is complete before the target is opened and written atomically (complete
or absent); a register a format cannot express leaves no file at all.  Names (the
report's, the part's) reach the text escaped: CSV cells through
:func:`~setupfix.outputs.writers.csv_cell`, a program's title comment through
:func:`parsers.folders.visible_name` (a name that is not UTF-8 or holds a line
break never breaks the file or the write).
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from setupfix.core.errors import ExportError, SourceLocation
from setupfix.correction.offsets import OffsetRow, offset_rows
from setupfix.correction.recommend import DRAFT_KEY, verdict_cell
from setupfix.model import ProcessModel
from setupfix.outputs.controllers import (
    PROGRAM_NUMBERS,
    check_program_number,
    derived_program_number,
    program_title,
    render,
)
from setupfix.outputs.writers import write_text
from setupfix.usecases.requests import CycleCorrection

__all__ = ["Exported", "cycle_rows", "offsets_text", "export", "program_number_of", "check_program_model"]


@dataclass(frozen=True)
class Exported:
    """What :func:`export` wrote: target, controller syntax, the exact text and its hash, the parts and rows,
    the program number (None for a format without a program name)."""

    target: str
    controller: str
    text: str
    sha256: str
    parts: tuple[str, ...]
    rows: tuple[OffsetRow, ...]
    program_number: int | None = None


def cycle_rows(cycle: CycleCorrection, current: Mapping[str, float] | None = None) -> list[OffsetRow]:
    """The offset rows of one cycle under the policy above (rows of a rejected cycle carry zeros).

    Raises
    ------
    MatchError
        If ``current`` lacks a correctable register.
    """
    return offset_rows(
        cycle.model,
        cycle.corrections,
        report=cycle.part.report,
        part=cycle.part.part,
        current=current,
        verdict=verdict_cell(cycle.recommendation),  # a stopped solve is never a plain apply or hold
    )


def check_program_model(model: ProcessModel, controller: str) -> None:
    """Refuse a controller program (every format but ``csv``) from a draft model (``[process] draft = true``).

    A draft's relations are a guess: its hold of zeros is no instruction a control should load
    (an incremental program of +0.000 blocks, an absolute one "safe to run again").  The offsets
    CSV still carries the hold rows with their verdict.

    Raises
    ------
    ExportError
        Naming the model file and the key to remove.
    """
    if model.draft and controller != "csv":
        raise ExportError(
            f"{controller}: the model is a draft ('{DRAFT_KEY}'): no program is written until its relations "
            f"are checked and the key removed from its [process] table",
            location=SourceLocation(model.source),
        )


def _check(cycles: Sequence[CycleCorrection], controller: str) -> None:
    for c in cycles:
        check_program_model(c.model, controller)
        if c.verdict == "reject":
            raise ExportError(
                f"part {c.part.part or '—'} is rejected, nothing exported: {c.recommendation.alarm}",
                location=SourceLocation(c.part.report or "<report>"),
            )
        if not c.solved:
            why = next(r.message for r in c.recommendation.rules if r.rule == "not_solved")
            raise ExportError(
                f"part {c.part.part or '—'} is not solved, nothing exported: {why}",
                location=SourceLocation(c.part.report or "<report>"),
            )
    if controller != "csv" and len(cycles) > 1:
        report = cycles[0].part.report or "<report>"
        raise ExportError(
            f"{controller}: a program holds one correction, the report has {len(cycles)} cycles "
            f"({', '.join(c.part.part or '—' for c in cycles)}): choose one with --part",
            location=SourceLocation(report),
        )


def program_number_of(
    cycles: Sequence[CycleCorrection], controller: str, program_number: int | None = None
) -> int | None:
    """The number the program of ``cycles`` gets: ``program_number`` checked against the format, else derived
    from the first cycle's report and part; None for a format without a program name.

    Raises
    ------
    ExportError
        ``program_number`` is one the format cannot hold.
    """
    if controller not in PROGRAM_NUMBERS:
        return None
    if program_number is not None:
        return check_program_number(controller, program_number)
    first = cycles[0].part if cycles else None
    return derived_program_number(first.report or "", first.part or "") if first else None


def offsets_text(
    cycles: Sequence[CycleCorrection],
    controller: str = "csv",
    current: Mapping[str, float] | None = None,
    program_number: int | None = None,
) -> str:
    """The exact text :func:`export` writes (offsets CSV or a controller program).

    Raises
    ------
    ExportError
        A rejected cycle, several cycles for a controller program, a register the
        format cannot express, or a program number it cannot hold.
    MatchError
        If ``current`` lacks a correctable register.
    """
    _check(cycles, controller)
    number = program_number_of(cycles, controller, program_number)
    if not cycles:
        return render(controller, [], program_number=number)
    rows = [row for c in cycles for row in cycle_rows(c, current)]
    title = program_title(cycles[0].part.report, cycles[0].part.part)  # one comment line, any name
    return render(controller, rows, title, program_number=number, spindle=cycles[0].model.spindle)


def export(
    cycles: Sequence[CycleCorrection],
    target: str,
    *,
    controller: str = "csv",
    current: Mapping[str, float] | None = None,
    program_number: int | None = None,
) -> Exported:
    """Write the offsets of ``cycles`` to ``target`` (``-``: standard output) atomically.

    ``current`` (the controller's current offsets by register ID) makes the rows
    absolute (mode *set*); ``program_number`` names the program (default derived, see
    the module docstring).

    Raises
    ------
    ExportError
        As :func:`offsets_text`, or the target cannot be written; nothing is written then.
    """
    text = offsets_text(cycles, controller, current, program_number)
    write_text(target, text)
    rows = tuple(row for c in cycles for row in cycle_rows(c, current))
    return Exported(
        str(target),
        controller,
        text,
        hashlib.sha256(text.encode("utf-8")).hexdigest(),
        tuple(c.part.part for c in cycles),
        rows,
        program_number_of(cycles, controller, program_number),
    )
