"""Elitist GA on the register grid: the paper's settings (the operators: tests/search/test_ga.py)."""

from __future__ import annotations

from setupfix.optimize.heuristics.ga import GA


def test_paper_settings_are_the_defaults() -> None:
    ga = GA()
    assert (ga.population, ga.mutation_rate, ga.n_solutions) == (50, 0.1, 5_000)
