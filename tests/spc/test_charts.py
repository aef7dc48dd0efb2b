"""Control-chart limits against a published example; Nelson rules against a brute-force reading of the rules."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from spc_examples import CONCENTRATION

from setupfix.core.errors import ParameterError
from setupfix.spc import D4, Violation, chart_limits, moving_range, nelson


def test_limits_match_the_published_example() -> None:
    lim = chart_limits(CONCENTRATION, baseline=20)
    # Montgomery & Runger, Table 16-3: UCL 105.99, CL 99.1, LCL 92.21; MR chart UCL = 3.267 · 2.59.
    assert lim.ucl == pytest.approx(105.99, abs=0.01)
    assert lim.center == pytest.approx(99.1, abs=0.005)
    assert lim.lcl == pytest.approx(92.21, abs=0.01)
    assert lim.mr_ucl == pytest.approx(D4 * 2.59, abs=0.02)
    assert lim.baseline == 20
    assert nelson(CONCENTRATION, lim.center, lim.sigma) == []  # "no indication of an out-of-control condition"


def test_limits_come_from_the_baseline_only() -> None:
    x = np.r_[np.tile([1.0, 2.0], 10), np.full(10, 100.0)]
    lim = chart_limits(x, baseline=20)
    assert lim.center == pytest.approx(1.5) and lim.mr_center == pytest.approx(1.0)
    assert moving_range([1.0, 3.0, 2.5]) == pytest.approx([2.0, 0.5])
    with pytest.raises(ParameterError, match="baseline"):
        chart_limits(x, baseline=1)


def _brute(x: list[float], c: float, s: float) -> dict[int, set[int]]:
    """Every rule by its words, point by point: each window that satisfies it, merged into stretches."""
    n = len(x)
    hits: dict[int, set[int]] = {1: set(), 2: set(), 3: set(), 4: set()}
    for i in range(n):
        if abs(x[i] - c) > 3 * s:
            hits[1].add(i)
    for i in range(n - 8):
        w = x[i : i + 9]
        if all(v > c for v in w) or all(v < c for v in w):
            hits[2].update(range(i, i + 9))
    for i in range(n - 5):
        w = x[i : i + 6]
        if all(w[k + 1] > w[k] for k in range(5)) or all(w[k + 1] < w[k] for k in range(5)):
            hits[3].update(range(i, i + 6))
    for i in range(n - 13):
        w = x[i : i + 14]
        d = [w[k + 1] - w[k] for k in range(13)]
        if all(d[k] * d[k + 1] < 0 for k in range(12)):
            hits[4].update(range(i, i + 14))
    return hits


def _covered(found: list[Violation]) -> dict[int, set[int]]:
    out: dict[int, set[int]] = {1: set(), 2: set(), 3: set(), 4: set()}
    for v in found:
        out[v.rule].update(v.points)
    return out


#: A clean stretch: no rule fires on it or across its joins (period 7, centred, small).
CLEAN = [0.3, -0.5, 0.4, 0.45, -0.2, 0.1, -0.55]


def _planted() -> tuple[np.ndarray, dict[int, list[tuple[int, int]]]]:
    parts: list[float] = CLEAN * 3  # 0..20: baseline
    where: dict[int, list[tuple[int, int]]] = {1: [], 2: [], 3: [], 4: []}
    parts += CLEAN
    where[1].append((len(parts), len(parts)))
    parts += [9.0]  # rule 1
    parts += CLEAN * 2
    start = len(parts)
    parts += [0.2, 0.6, 0.3, 0.5, 0.25, 0.7, 0.4, 0.35, 0.65]  # rule 2: nine above, no trend
    where[2].append((start, len(parts) - 1))
    parts += [-0.3] + CLEAN * 2
    start = len(parts)
    parts += [-0.9, -0.6, -0.3, 0.05, 0.35, 0.8]  # rule 3: six rising
    where[3].append((start, len(parts) - 1))
    parts += [-0.4] + CLEAN * 2 + [0.6]  # down into the first point: the alternation starts there
    start = len(parts)
    parts += [0.5, -0.5] * 7  # rule 4: fourteen alternating
    where[4].append((start, len(parts) - 1))
    parts += [-0.6, -0.2] + CLEAN * 2  # down again: it ends there
    return np.asarray(parts), where


def test_clean_data_flags_nothing() -> None:
    x = np.asarray(CLEAN * 12)
    lim = chart_limits(x)
    assert nelson(x, lim.center, lim.sigma) == []
    assert all(not v for v in _brute(list(x), lim.center, lim.sigma).values())


def test_planted_violations_are_flagged_where_they_are_and_nowhere_else() -> None:
    x, where = _planted()
    lim = chart_limits(x, baseline=21)
    found = nelson(x, lim.center, lim.sigma)
    got = {r: [(v.start, v.end) for v in found if v.rule == r] for r in (1, 2, 3, 4)}
    assert got == where
    assert _covered(found) == _brute(list(x), lim.center, lim.sigma)


@pytest.mark.parametrize("seed", range(20))
def test_rules_agree_with_brute_force_on_random_series(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(0, 1, 120) + np.where(rng.random(120) < 0.05, 4, 0), 1)  # ties, spikes
    if seed % 3 == 0:
        x[40:60] += 1.5  # a shift: long rule-2 runs
    if seed % 4 == 0:
        x[70:84] = np.tile([1.0, -1.0], 7)
    lim = chart_limits(x)
    found = nelson(x, lim.center, lim.sigma)
    assert _covered(found) == _brute(list(x), lim.center, lim.sigma)
    for rule in (1, 2, 3, 4):  # stretches of one rule never touch: each is maximal
        spans = sorted((v.start, v.end) for v in found if v.rule == rule)
        assert all(b[0] > a[1] for a, b in itertools.pairwise(spans))
