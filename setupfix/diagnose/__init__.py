"""Close the loop: find the residual the declared model leaves, trace it, add the effect.

Engine (layer 3, arrays in and out, no file I/O):

* :mod:`~setupfix.diagnose.terms` — the series, the layout and the effect terms;
* :mod:`~setupfix.diagnose.fit` — least squares of the declared model (setup state
  on the row space of C) with or without effects;
* :mod:`~setupfix.diagnose.candidates` — the candidates a series allows (one-column terms,
  per-register process sets, refined level and saturating-drift positions);
* :mod:`~setupfix.diagnose.scores` — what each candidate explains and its per-cycle test;
* :mod:`~setupfix.diagnose.inference` — the tests with the cycle as the unit of evidence;
* :mod:`~setupfix.diagnose.support` — support rules and diagnosability;
* :mod:`~setupfix.diagnose.factors` — declared design factors, tested as a family of their own;
* :mod:`~setupfix.diagnose.log_family` — without declared factors, the process log's own columns
  tested first as the user's family (forward inside it, max-T over permutations of the parts);
* :mod:`~setupfix.diagnose.select` — forward selection (ranked by what each explains, accepted on
  its per-cycle test with Bonferroni and cross-validation over cycles; keeps trying);
* :mod:`~setupfix.diagnose.walk` — walk forward (declared, augmented, EWMA, none) and
  the next-cycle forecast;
* :mod:`~setupfix.diagnose.forecast` — the change an ``[effects]`` section predicts
  until the next cycle (used by ``correct``);
* :mod:`~setupfix.diagnose.shop` — the closed-loop shop simulator.
"""

from setupfix.diagnose.core import Diagnoser, Diagnosis, EffectResult, ErrorSummary, error_summary
from setupfix.diagnose.factors import FactorTest, FactorTests, Term, factor_tests, parse_terms
from setupfix.diagnose.fit import Fit, fit_model
from setupfix.diagnose.select import Selection, candidate_specs, select_effects
from setupfix.diagnose.shop import HiddenEffect, ShopSimulator, SimulatedSeries
from setupfix.diagnose.terms import KINDS, EffectSpec, Layout, Series
from setupfix.diagnose.walk import WalkForward, next_cycle, walk_forward

__all__ = [
    "KINDS",
    "Diagnoser",
    "Diagnosis",
    "EffectResult",
    "EffectSpec",
    "ErrorSummary",
    "FactorTest",
    "FactorTests",
    "Fit",
    "HiddenEffect",
    "Term",
    "parse_terms",
    "factor_tests",
    "Layout",
    "Selection",
    "Series",
    "ShopSimulator",
    "SimulatedSeries",
    "WalkForward",
    "candidate_specs",
    "error_summary",
    "fit_model",
    "next_cycle",
    "select_effects",
    "walk_forward",
]
