"""Use case "model show": a process model's matrices, rank and null space."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.model import ProcessModel, load_model
from setupfix.relation import RelationMatrices, null_space_directions, relation_matrices

__all__ = ["ModelDescription", "describe_model"]


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
            "name": self.model.name, "axis": self.model.axis, "unit": self.model.unit,
            "registers": m.registers, "features": m.features, "dimensions": m.dimensions,
            "R_MW": m.R_MW.tolist(), "R_WF": m.R_WF.tolist(), "R_TF": m.R_TF.tolist(), "R_FD": m.R_FD.tolist(),
            "composite": m.composite.tolist(), "rank": self.rank,
            "null_space": [dict(zip(m.registers, v.tolist())) for v in self.null_space],
        }


def describe_model(path: str | Path | ProcessModel) -> ModelDescription:
    model = path if isinstance(path, ProcessModel) else load_model(path)
    mats = relation_matrices(model)
    comp = mats.composite
    rank = int(np.linalg.matrix_rank(comp)) if comp.size else 0
    return ModelDescription(model, mats, rank, null_space_directions(comp))
