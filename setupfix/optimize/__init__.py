"""Optimisers of the setup corrections: one interface, one result type.

``get_optimizer(name, seed=…, **hyper_parameters).solve(problem)`` returns an
:class:`OptimizeResult`.  ``exact`` (LP + MILP with HiGHS) is the default and the
yardstick; the metaheuristics follow Stryczek (2014) and the papers it cites.
"""

from __future__ import annotations

import importlib
from typing import Any

from setupfix.optimize._base import Evaluator, Metaheuristic, Optimizer, make_result
from setupfix.optimize._problem import CorrectionProblem, OptimizeResult

__all__ = [
    "OPTIMIZERS",
    "CorrectionProblem",
    "Evaluator",
    "Metaheuristic",
    "OptimizeResult",
    "Optimizer",
    "get_optimizer",
    "make_result",
]

#: Registry: name → "module:Class".  Imported lazily so one broken optimiser never
#: stops the others.
OPTIMIZERS: dict[str, str] = {
    "exact": "setupfix.optimize._exact:ExactOptimizer",
    "cripso": "setupfix.optimize._cripso:CRIPSO",
    "pso": "setupfix.optimize._pso:PSO",
    "ga": "setupfix.optimize._ga:GA",
    "coa": "setupfix.optimize._coa:COA",
    "cs": "setupfix.optimize._cs:CuckooSearch",
}


def get_optimizer(name: str, **params: Any) -> Optimizer:
    """Instantiate the optimiser registered as ``name`` with its hyper-parameters.

    Raises
    ------
    KeyError
        If no optimiser has that name.
    """
    try:
        target = OPTIMIZERS[name]
    except KeyError:
        raise KeyError(f"unknown optimizer {name!r} (known: {', '.join(OPTIMIZERS)})") from None
    module, cls = target.split(":")
    optimizer: Optimizer = getattr(importlib.import_module(module), cls)(**params)
    return optimizer
