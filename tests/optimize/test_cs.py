"""Cuckoo search on the register grid: the defaults (the search itself: tests/search/test_cs.py)."""

from __future__ import annotations

from setupfix.optimize.heuristics.cs import CuckooSearch


def test_defaults() -> None:
    cs = CuckooSearch()
    assert (cs.n_nests, cs.pa, cs.alpha, cs.beta, cs.n_solutions) == (25, 0.25, 0.01, 1.5, 5_000)
