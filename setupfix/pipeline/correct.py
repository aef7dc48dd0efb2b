"""Use case "correct": from a process model and a CMM report to register corrections.

Shared by ``setupfix correct``, batch processing and the TUI.  The steps are
load the model → read the report (any supported format) → tie characteristics to
dimensions (part by part, stations merged into fixture cycles) → pose the
problem → optimise → a :class:`PartCorrection` per cycle.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import parsers
from setupfix.errors import MatchError, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts, normalise_name
from setupfix.offsets import OffsetRow, offset_rows
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer

__all__ = ["PartCorrection", "assign_stations", "load_parts", "select_parts", "correct_part", "correct_report"]


@dataclass
class PartCorrection:
    """The correction of one measured cycle and everything needed to show it."""

    model: ProcessModel
    part: PartMeasurement
    problem: CorrectionProblem
    result: OptimizeResult
    warnings: list[str] = field(default_factory=list)

    @property
    def corrections(self) -> dict[str, float]:
        """Correction of every correctable register by model ID, zero included."""
        return {rid: float(v) for rid, v, reg in zip(self.problem.register_ids, self.result.x,
                                                     self.model.registers) if not reg.fixed}

    def dimension_rows(self) -> list[dict[str, Any]]:
        """Per measured dimension: id, name, deviation, limits, predicted, margin after."""
        dims = {d.id: d for d in self.model.dimensions}
        predicted = self.problem.predicted(self.result.x)
        margins = self.problem.margins(self.result.x)
        rows = []
        for i, did in enumerate(self.problem.dimension_ids):
            d = dims[did]
            rows.append({
                "id": did, "name": d.name, "deviation": float(self.problem.deviation[i]),
                "predicted": float(predicted[i]), "lower": d.lower, "upper": d.upper,
                "margin": float(margins[i]),
            })
        return rows

    def offsets(self) -> list[OffsetRow]:
        return offset_rows(self.model, self.corrections, report=self.part.report, part=self.part.part)

    def to_json(self) -> dict[str, Any]:
        """The ``correct --json`` object of ``../shared/spec/cli-json.md`` (plus extra keys)."""
        digits = 9
        r = self.result
        names = {d.id: d.name for d in self.model.dimensions}
        return {
            "part": self.part.part,
            "report": self.part.report,
            "optimizer": r.optimizer,
            "status": r.status,
            "margin_before": round(r.margin_before, digits),
            "margin_after": round(r.margin_after, digits),
            "bonus": round(r.bonus, digits),
            "norm": round(r.norm, digits),
            "bound": None if r.bound is None else round(r.bound, digits),
            "in_tolerance": r.in_tolerance,
            "message": r.message,
            "corrections": {k: round(v, digits) for k, v in self.corrections.items()},
            "binding": [names[b] for b in r.binding],
            "dimensions": [
                {k: (round(v, digits) if isinstance(v, float) and np.isfinite(v) else
                     (None if isinstance(v, float) else v))
                 for k, v in row.items()}
                for row in self.dimension_rows()
            ],
            "absent": list(self.part.absent),
            "unmatched": list(self.part.unmatched),
            "evaluations": r.evaluations,
            "seconds": round(r.seconds, 6),
        }


def assign_stations(model: ProcessModel, table: pd.DataFrame,
                    stations: Sequence[str] | Mapping[str, str] | None = None) -> pd.DataFrame:
    """Map the parts of a multi-part report to fixture stations (model ``group``).

    A CMM report often holds one "part" per physical workpiece while a setup
    correction concerns one fixture cycle holding several workpieces.  With
    ``stations`` (a list in part order, or a mapping part → station), or when every
    part value names a model group, the parts become stations of one cycle.

    Raises
    ------
    MatchError
        If a station is not a group of the model, or the list length differs from
        the number of parts.
    """
    groups = {normalise_name(d.group): d.group for d in model.dimensions if d.group}
    parts = table["part"].fillna("").astype(str)
    order = list(dict.fromkeys(parts))
    report = str(table["report"].iloc[0]) if "report" in table and len(table) else "<report>"
    if stations is None:
        if len(order) > 1 and all(normalise_name(p) in groups for p in order):
            mapping = {p: groups[normalise_name(p)] for p in order}
        else:
            return table
    elif isinstance(stations, Mapping):
        mapping = dict(stations)
    else:
        if len(stations) != len(order):
            raise MatchError(f"{len(stations)} stations given for {len(order)} parts in the report "
                             f"({', '.join(order)})", location=SourceLocation(report))
        mapping = dict(zip(order, stations))
    for part, station in mapping.items():
        if normalise_name(station) not in groups:
            raise MatchError(f"station {station!r} (for part {part!r}) is not a group of the model "
                             f"(groups: {', '.join(sorted(set(groups.values())))})", location=SourceLocation(report))
    out = table.copy()
    out["station"] = parts.map(lambda p: mapping.get(p, ""))
    out["part"] = "cycle"
    return out


def load_parts(model: ProcessModel, report: str | Path, *, format: str | None = None, unit: str | None = None,
               encoding: str | None = None, columns: str | None = None,
               stations: Sequence[str] | Mapping[str, str] | None = None) -> list[PartMeasurement]:
    """Read a report in any supported format and tie it to the model, cycle by cycle."""
    options: dict[str, Any] = {"unit": unit, "encoding": encoding}
    if columns:
        options["columns"] = columns
    table = parsers.read(report, format=format, **options)
    table = assign_stations(model, table, stations)
    return match_parts(model, table, source=str(report))


def correct_part(model: ProcessModel, part: PartMeasurement, *, optimizer: str = "exact",
                 seed: int | None = None, **params: Any) -> PartCorrection:
    """Optimise the corrections of one measured cycle."""
    problem = CorrectionProblem.from_part(model, part)
    opt = get_optimizer(optimizer, seed=seed, **params)
    result = opt.solve(problem)
    notes = []
    if part.absent:
        notes.append(f"{len(part.absent)} dimension(s) absent from the report, left out: {', '.join(part.absent)}")
    if part.unmatched:
        notes.append(f"{len(part.unmatched)} characteristic(s) match no dimension: {', '.join(part.unmatched[:8])}"
                     + (" …" if len(part.unmatched) > 8 else ""))
    return PartCorrection(model=model, part=part, problem=problem, result=result, warnings=notes)


def correct_report(model: ProcessModel | str | Path, report: str | Path, *, optimizer: str = "exact",
                   seed: int | None = None, part: str | None = None, format: str | None = None,
                   unit: str | None = None, encoding: str | None = None, columns: str | None = None,
                   stations: Sequence[str] | Mapping[str, str] | None = None) -> list[PartCorrection]:
    """Correct every cycle of a report (or the one named by ``part``)."""
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    parts = load_parts(model, report, format=format, unit=unit, encoding=encoding, columns=columns,
                       stations=stations)
    return [correct_part(model, p, optimizer=optimizer, seed=seed) for p in select_parts(parts, part, report)]


def select_parts(parts: list[PartMeasurement], part: str | None, report: str | Path) -> list[PartMeasurement]:
    """All parts, or only the one named ``part``.

    Raises
    ------
    MatchError
        If no part of the report has that name (the message lists the names).
    """
    if part is None:
        return parts
    chosen = [p for p in parts if p.part == part]
    if not chosen:
        raise MatchError(f"no part {part!r} in the report (parts: {', '.join(p.part or '(none)' for p in parts)})",
                         location=SourceLocation(str(report)))
    return chosen
