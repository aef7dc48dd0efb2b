"""Offsets CSV: the corrections to type into (or send to) the controller.

Columns per ``../shared/spec/cli-json.md``: report, part, id, register, kind, axis,
delta.  One row per correctable register, zero included, so that the file is a
complete instruction ("leave H23 as it is" is an instruction too).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from setupfix.model import ProcessModel

__all__ = ["OFFSET_COLUMNS", "OffsetRow", "offset_rows", "offsets_csv_text"]

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


def _decimals(resolution: float) -> int:
    """Decimals that show every multiple of the register resolution exactly."""
    return max(0, min(9, math.ceil(-math.log10(resolution) - 1e-9)))


def offset_rows(model: ProcessModel, corrections: Mapping[str, float], *, report: str = "",
                part: str = "") -> list[OffsetRow]:
    """Rows for every correctable (non-fixed) register of ``model``, in model order."""
    digits = _decimals(model.resolution)
    rows = []
    for reg in model.registers:
        if reg.fixed:
            continue
        delta = round(float(corrections.get(reg.id, 0.0)), digits) + 0.0  # + 0.0 turns -0.0 into 0.0
        rows.append(OffsetRow(report, part, reg.id, reg.register, reg.kind, model.axis, delta))
    return rows


def offsets_csv_text(rows: Iterable[OffsetRow], *, resolution: float = 0.001) -> str:
    """The offsets CSV of ``rows``, deltas with the decimals of ``resolution``.

    Written by :func:`setupfix.pipeline.writers.write_offsets_csv`.
    """
    digits = _decimals(resolution)
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(OFFSET_COLUMNS)
    for r in rows:
        writer.writerow([r.report, r.part, r.id, r.register, r.kind, r.axis, f"{r.delta:.{digits}f}"])
    return stream.getvalue()
