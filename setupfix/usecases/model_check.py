"""Use cases "model show" (matrices, rank, null space) and "model check" (a report's match table)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import MatchError
from setupfix.correction.relation import RelationMatrices, null_space_directions, relation_matrices
from setupfix.inputs.checks import difference_threshold
from setupfix.inputs.cycles import Stations, load_parts
from setupfix.model import Dimension, PartMeasurement, ProcessModel, load_model
from setupfix.model.measurements import closest_names, report_names

__all__ = ["MatchTable", "ModelDescription", "check_report", "describe_model"]


@dataclass(frozen=True)
class ModelDescription:
    """A loaded model with its relation matrices (eqs. 3–4) and what they imply."""

    model: ProcessModel
    matrices: RelationMatrices
    rank: int
    null_space: npt.NDArray[np.float64]

    def to_json(self) -> dict[str, Any]:
        m = self.matrices
        return {
            "name": self.model.name,
            "axis": self.model.axis,
            # a multi-axis model: what it corrects along besides the (spindle) axis above
            **({"axes": list(self.model.axes), "spindle": self.model.spindle} if self.model.multi_axis else {}),
            "unit": self.model.unit,
            "registers": m.registers,
            "features": m.features,
            "dimensions": m.dimensions,
            "R_MW": m.R_MW.tolist(),
            "R_WF": m.R_WF.tolist(),
            "R_TF": m.R_TF.tolist(),
            "R_FD": m.R_FD.tolist(),
            "composite": m.composite.tolist(),
            "rank": self.rank,
            "null_space": [dict(zip(m.registers, v.tolist(), strict=True)) for v in self.null_space],
        }


def describe_model(path: str | Path | ProcessModel) -> ModelDescription:
    model = path if isinstance(path, ProcessModel) else load_model(path)
    mats = relation_matrices(model)
    comp = mats.composite
    rank = int(np.linalg.matrix_rank(comp)) if comp.size else 0
    return ModelDescription(model, mats, rank, null_space_directions(comp))


@dataclass(frozen=True)
class MatchTable:
    """How a report's characteristics tie to a model's dimensions, part by part (``model check``)."""

    model: ProcessModel
    report: str
    parts: list[PartMeasurement]

    def rows(self, part: PartMeasurement) -> list[dict[str, Any]]:
        """Per model dimension: its report name, nominal and limits beside the model's (NaN: not given)."""
        out = []
        for i, d in enumerate(self.model.dimensions):
            measured = bool(part.measured[i])
            given = {
                k: _value(v, i) if measured else None
                for k, v in (("nominal", part.nominal), ("lower", part.lower), ("upper", part.upper))
            }
            thr = difference_threshold(self.model, d.lower, d.upper)
            model_values = {"nominal": d.nominal, "lower": d.lower, "upper": d.upper}
            differs = any(v is not None and abs(v - model_values[k]) > thr for k, v in given.items())
            out.append(
                {
                    "id": d.id,
                    "name": d.name,
                    "station": d.group,
                    "matched": measured,
                    "characteristic": part.names[i] if measured else None,
                    "source": part.sources[i] if measured else None,
                    **model_values,
                    "report_nominal": given["nominal"],
                    "report_lower": given["lower"],
                    "report_upper": given["upper"],
                    "differs": differs,
                    "closest": [] if measured else list(_closest(d, part.unmatched)),
                }
            )
        return out

    def to_json(self) -> dict[str, Any]:
        return {
            "model": self.model.source,
            "report": self.report,
            "parts": [
                {
                    "part": p.part,
                    "matched": int(p.measured.sum()),
                    "dimensions": self.rows(p),
                    "absent": list(p.absent),
                    "unmatched": [{"name": n, "closest": list(p.suggestions.get(n, ()))} for n in p.unmatched],
                    "notes": [
                        {"message": n.message, "location": str(n.location) if n.location else None, "kind": n.kind}
                        for n in p.notes
                    ],
                }
                for p in self.parts
            ],
        }


def _value(values: npt.NDArray[np.float64] | None, i: int) -> float | None:
    if values is None or not np.isfinite(values[i]):
        return None
    return float(values[i])


def _closest(dim: Dimension, names: tuple[str, ...], n: int = 3) -> tuple[str, ...]:
    """Unmatched report names closest to an absent dimension (:func:`closest_names`, the one rule)."""
    return tuple(dict.fromkeys(c for o in report_names(dim) for c in closest_names(o, names, n)))[:n]


def check_report(
    model: ProcessModel | str | Path,
    report: str | Path,
    *,
    format: str | None = None,
    unit: str | None = None,
    encoding: str | None = None,
    columns: str | None = None,
    stations: Stations | None = None,
    parts_per_cycle: int | None = None,
    strict: bool = False,
    lenient: bool = False,
) -> MatchTable:
    """Read a report and tie it to the model without correcting: the match table of ``model check``."""
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    try:
        parts = load_parts(
            model,
            report,
            format=format,
            unit=unit,
            encoding=encoding,
            columns=columns,
            stations=stations,
            parts_per_cycle=parts_per_cycle,
            strict=strict,
            lenient=lenient,
        )
    except MatchError as exc:
        if not exc.message.startswith("no characteristic of part"):
            raise
        # the matcher's hint sends the user here ('model check'): say instead what the model's names are
        raise MatchError(exc.message, location=exc.location, hint=_names_hint(model)) from None
    return MatchTable(model, str(report), parts)


def _names_hint(model: ProcessModel) -> str:
    """What to do when no report name is a model name: the model's names, and the two ways to tie them."""
    names = ", ".join(repr(d.name) for d in model.dimensions[:3]) + (", …" if len(model.dimensions) > 3 else "")
    grouped = any(d.group for d in model.dimensions)
    return (
        f"the model's dimensions are named {names}: add the report's names as aliases = [\"…\"] in "
        "[dimensions.*]"
        + (
            "; a per-part report of a fixture station matches its station's dimensions by "
            "their names as written with --stations <station> (station templates)"
            if grouped
            else ""
        )
    )
