"""Labels a person can act on: factor levels in words with their parts."""

from __future__ import annotations

import numpy as np

from setupfix.diagnose import EffectSpec, Series
from setupfix.views.analysis import level_words


def _series(columns: dict[str, list[float]], cycles: tuple[str, ...]) -> Series:
    n = len(cycles)
    temp = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()])
    names = tuple(columns)
    return Series(
        np.zeros((n, 1)),
        np.arange(n, dtype=float),
        np.zeros((n, 1)),
        np.zeros((n, 0)),
        temp,
        names,
        cycles,
        process_channels=names,
    )


def test_a_level_is_said_in_words_with_its_parts_as_runs() -> None:
    s = _series({"stick=Long": [0, 0, 1, 1, 1, 0, 1], "speed=Low": [1, 0, 1, 0, 1, 0, 0]}, tuple("1234567"))
    assert level_words(EffectSpec("process", channel="stick=Long", register="T4"), s) == "stick Long (parts 3–5, 7)"
    both = EffectSpec("process", channel="stick=Long & speed=Low", register="T4")
    assert level_words(both, s) == "stick Long and speed Low (parts 3, 5)"
    assert level_words(EffectSpec("wear", register="T4"), s) is None


def test_parts_without_numbers_are_listed() -> None:
    s = _series({"batch=B": [1, 1, 0, 1, 1, 1, 1, 1]}, tuple(f"P{i}" for i in range(8)))
    assert (
        level_words(EffectSpec("process", channel="batch=B"), s) == "batch B (parts P0, P1, P3, P4, P5, P6 and 1 more)"
    )
