"""Offsets CSV: the corrections to type into (or send to) the controller.

Columns per ``../shared/spec/cli-json.md``: report, part, id, register, kind, axis,
delta.  One row per correctable register, zero included, so that the file is a
complete instruction ("leave H23 as it is" is an instruction too).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from setupfix.atomic import atomic_write
from setupfix.model import ProcessModel

__all__ = ["grid_decimals", "OFFSET_COLUMNS", "OffsetRow", "offset_rows", "write_offsets_csv"]

OFFSET_COLUMNS = ("report", "part", "id", "register", "kind", "axis", "delta")


@dataclass(frozen=True)
class OffsetRow:
    """One register change, as written to the offsets CSV."""

    report: str
    part: str
    id: str
    register: str
    kind: str
    axis: str
    delta: float


def grid_decimals(resolution: float) -> int:
    """Decimals that show every multiple of the register resolution exactly (0…9)."""
    return max(0, min(9, math.ceil(-math.log10(resolution) - 1e-9)))


def offset_rows(model: ProcessModel, corrections: Mapping[str, float], *, report: str = "",
                part: str = "") -> list[OffsetRow]:
    """Rows for every correctable (non-fixed) register of ``model``, in model order."""
    digits = grid_decimals(model.resolution)
    rows = []
    for reg in model.registers:
        if reg.fixed:
            continue
        delta = round(float(corrections.get(reg.id, 0.0)), digits) + 0.0  # + 0.0 turns -0.0 into 0.0
        rows.append(OffsetRow(report, part, reg.id, reg.register, reg.kind, model.axis, delta))
    return rows


def write_offsets_csv(rows: Iterable[OffsetRow], target: str | Path, *, resolution: float = 0.001) -> None:
    """Write offset rows atomically (``target == "-"``: standard output)."""
    digits = grid_decimals(resolution)
    with atomic_write(target) as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(OFFSET_COLUMNS)
        for r in rows:
            writer.writerow([r.report, r.part, r.id, r.register, r.kind, r.axis, f"{r.delta:.{digits}f}"])
