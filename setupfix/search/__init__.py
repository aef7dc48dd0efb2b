"""Seeded, budgeted population searches over a space: one implementation of each algorithm.

Every search here *minimises* a vectorised objective ``f(X) -> values`` (``X`` of
shape (m, n)) over a :class:`Space`, draws every random number from the one
:class:`numpy.random.Generator` it is given, and stops when its budget of evaluated
points is spent.  Two spaces use them:

* :class:`Box` — a continuous box, clipped (the thermal models' calibration,
  :mod:`setupfix.thermal.calibrate`);
* the register grid of a :class:`~setupfix.optimize.CorrectionProblem` (snapped
  onto the resolution grid inside the register limits), the adaptor in
  :mod:`setupfix.optimize.base` for the setup-correction optimisers (which
  maximise f = 10·f1 − f2 and so minimise −f here).

Algorithms: :func:`cuckoo_search` (Yang & Deb 2009), :func:`particle_swarm`
(inertia PSO, synchronous or asynchronous, constant or eq.-11 coefficients),
:func:`tournament_ga` (elitist (μ + λ) GA of Stryczek's comparison) and
:func:`roulette_ga` (floating-point GA of Wang et al. 2017).  They are written here
rather than taken from scipy because scipy has none of them, and the research notes
found the third-party libraries either pinned to old numpy or deviating from the
published algorithms.
"""

from __future__ import annotations

from setupfix.search.cs import cuckoo_search, levy_steps, mantegna_sigma
from setupfix.search.ga import roulette_ga, tournament_ga
from setupfix.search.pso import acceleration, particle_swarm
from setupfix.search.space import DEFAULT_SEED, Box, Objective, Observer, SearchResult, Space, generator

__all__ = [
    "DEFAULT_SEED",
    "generator",
    "Space",
    "Box",
    "Objective",
    "Observer",
    "SearchResult",
    "cuckoo_search",
    "particle_swarm",
    "tournament_ga",
    "roulette_ga",
    "levy_steps",
    "mantegna_sigma",
    "acceleration",
]
