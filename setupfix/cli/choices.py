"""Names the argument parser offers as choices, without importing what they name.

``setupfix --help`` and ``--version`` must not load numpy, pandas or scipy, so the
parser cannot ask the registries (which import their engines).  These tuples repeat
the registries' keys; ``tests/cli/test_lazy_imports.py`` checks that they agree.
"""

from __future__ import annotations

#: setupfix.optimize.OPTIMIZERS
OPTIMIZERS: tuple[str, ...] = ("coa", "cripso", "cs", "exact", "ga", "pso")
#: setupfix.outputs.controllers.CONTROLLERS
CONTROLLERS: tuple[str, ...] = ("csv", "fanuc", "haas", "heidenhain", "siemens", "fanuc-macro", "haas-macro")
#: setupfix.usecases.history.EXPORTS
HISTORY_EXPORTS: tuple[str, ...] = ("measurements", "corrections", "temperatures", "recommendations", "dfq")
#: setupfix.thermal.registry.methods()
THERMAL_METHODS: tuple[str, ...] = ("mra", "grey-ls", "grey-cs", "grey-pso", "kalman")
#: setupfix.usecases.simulate.START
SIMULATE_START = "2026-11-02T06:00:00"
