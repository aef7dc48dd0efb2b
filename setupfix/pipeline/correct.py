"""Use case "correct": from a process model and a CMM report to register corrections.

Shared by ``setupfix correct``, batch processing and the TUI.  The steps are
load the model → read the report (any supported format) → tie characteristics to
dimensions (part by part, stations merged into fixture cycles) → pose the
problem → optimise → a :class:`PartCorrection` per cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from setupfix.errors import MatchError, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, load_model
from setupfix.offsets import OffsetRow, offset_rows
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.pipeline.cycles import Stations, assign_stations, load_parts  # noqa: F401 - re-exported

__all__ = ["PartCorrection", "assign_stations", "load_parts", "select_parts", "correct_part", "correct_report"]


@dataclass
class PartCorrection:
    """The correction of one measured cycle and everything needed to show it."""

    model: ProcessModel
    part: PartMeasurement
    problem: CorrectionProblem
    result: OptimizeResult
    warnings: list[str] = field(default_factory=list)
    #: Thermal feed-forward step (``correct --thermal``), set by setupfix.pipeline.feedforward.apply_feed_forward.
    thermal: Any = None

    @property
    def corrections(self) -> dict[str, float]:
        """Correction of every correctable register by model ID, zero included (thermal feed-forward added)."""
        out = {rid: float(v) for rid, v, reg in zip(self.problem.register_ids, self.result.x,
                                                    self.model.registers) if not reg.fixed}
        for rid, shift in (self.thermal.corrections() if self.thermal is not None else {}).items():
            out[rid] = out.get(rid, 0.0) + shift
        return out

    def dimension_rows(self) -> list[dict[str, Any]]:
        """Per measured dimension: id, name, deviation, limits, predicted, margin after."""
        dims = {d.id: d for d in self.model.dimensions}
        predicted = self.problem.predicted(self.result.x)
        margins = self.problem.margins(self.result.x)
        rows = []
        for i, did in enumerate(self.problem.dimension_ids):
            d = dims[did]
            rows.append({
                "id": did, "name": d.name, "station": d.group, "deviation": float(self.problem.deviation[i]),
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
            "suggestions": {name: list(near) for name, near in self.part.suggestions.items()},
            "evaluations": r.evaluations,
            "seconds": round(r.seconds, 6),
        } | ({"thermal": self.thermal.to_json()} if self.thermal is not None else {})


def correct_part(model: ProcessModel, part: PartMeasurement, *, optimizer: str = "exact",
                 seed: int | None = None, **params: Any) -> PartCorrection:
    """Optimise the corrections of one measured cycle."""
    problem = CorrectionProblem.from_part(model, part)
    opt = get_optimizer(optimizer, seed=seed, **params)
    result = opt.solve(problem)
    notes = [str(n) for n in part.notes]
    if part.absent:
        notes.append(f"{len(part.absent)} dimension(s) absent from the report, left out: {', '.join(part.absent)}")
    if part.unmatched:
        notes.append(f"{len(part.unmatched)} characteristic(s) match no dimension: {', '.join(part.unmatched[:8])}"
                     + (" …" if len(part.unmatched) > 8 else ""))
    return PartCorrection(model=model, part=part, problem=problem, result=result, warnings=notes)


def correct_report(model: ProcessModel | str | Path, report: str | Path, *, optimizer: str = "exact",
                   seed: int | None = None, part: str | None = None, format: str | None = None,
                   unit: str | None = None, encoding: str | None = None, columns: str | None = None,
                   stations: Stations | None = None, parts_per_cycle: int | None = None,
                   strict: bool = False) -> list[PartCorrection]:
    """Correct every cycle of a report (or the one named by ``part``)."""
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    parts = load_parts(model, report, format=format, unit=unit, encoding=encoding, columns=columns,
                       stations=stations, parts_per_cycle=parts_per_cycle, strict=strict)
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
