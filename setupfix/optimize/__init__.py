"""Optimisers of the setup corrections: one interface, one result type.

``get_optimizer(name, seed=…, **hyper_parameters).solve(problem)`` returns an
:class:`OptimizeResult`.  ``exact`` (LP + MILP with HiGHS) is the default and the
yardstick; the metaheuristics follow Stryczek (2014) and the papers it cites.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from setupfix.core.errors import ParameterError
from setupfix.optimize.base import NO_BETTER_THAN_NONE, Evaluator, Metaheuristic, Optimizer, make_result
from setupfix.optimize.dimensions import dimension_floor, harmed_columns, model_dimensions
from setupfix.optimize.problem import CorrectionProblem, OptimizeResult, Status, Stopped, TriageRecord

__all__ = [
    "OPTIMIZERS",
    "CorrectionProblem",
    "Evaluator",
    "Metaheuristic",
    "NO_BETTER_THAN_NONE",
    "OptimizeResult",
    "Optimizer",
    "Status",
    "Stopped",
    "TriageRecord",
    "dimension_floor",
    "get_optimizer",
    "harmed_columns",
    "make_result",
    "model_dimensions",
]

#: Registry: name → "module:Class".  Imported lazily so one broken optimiser never
#: stops the others.
OPTIMIZERS: dict[str, str] = {
    "exact": "setupfix.optimize.exact.solve:ExactOptimizer",
    "cripso": "setupfix.optimize.heuristics.cripso:CRIPSO",
    "pso": "setupfix.optimize.heuristics.pso:PSO",
    "ga": "setupfix.optimize.heuristics.ga:GA",
    "coa": "setupfix.optimize.heuristics.coa:COA",
    "cs": "setupfix.optimize.heuristics.cs:CuckooSearch",
}


def get_optimizer(name: str, **params: Any) -> Optimizer:
    """Instantiate the optimiser registered as ``name`` with its hyper-parameters, validated.

    Raises
    ------
    ParameterError
        If no optimiser has that name (the message lists the names), a parameter is
        unknown to it, or a value is outside its declared range.
    """
    target = OPTIMIZERS.get(name) if isinstance(name, str) else None
    if target is None:
        raise ParameterError(f"optimizer must be one of {', '.join(sorted(OPTIMIZERS))}, got {name!r}")
    module, cls_name = target.split(":")
    cls = getattr(importlib.import_module(module), cls_name)
    known = set(inspect.signature(cls).parameters)
    unknown = sorted(set(params) - known)
    if unknown:
        raise ParameterError(
            f"{cls.__name__}: unknown parameter {unknown[0]!r} (parameters: {', '.join(sorted(known))})"
        )
    optimizer: Optimizer = cls(**params)
    optimizer.validate_params()
    return optimizer
