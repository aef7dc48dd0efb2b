"""Individuals (X) and moving-range (MR) control charts and the Nelson rules.

Limits come from a baseline window (the first ``baseline`` values) and are applied to
the whole series:

* X chart: centre x̄_b, σ = MR̄_b / d2, UCL/LCL = x̄_b ± 3σ;
* MR chart: centre MR̄_b, UCL = D4 · MR̄_b with D4 = 3.267 (span 2), LCL = 0.

Nelson's rules (L. S. Nelson, "The Shewhart control chart — tests for special causes",
Journal of Quality Technology 16 (1984) 237–239), numbered as he did:

1. one point more than 3σ from the centre line;
2. nine points in a row on the same side of the centre line;
3. six points in a row steadily increasing or decreasing;
4. fourteen points in a row alternating up and down.

Each violation is one maximal stretch (a run longer than the rule's length is one
violation covering all of it; rule 1 one violation per point); a point on the centre
line ends a run of rule 2, an equal neighbour ends a run of rules 3 and 4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from setupfix.core.errors import ParameterError
from setupfix.spc.capability import D2

__all__ = ["D4", "NELSON_RULES", "ChartLimits", "Violation", "chart_limits", "moving_range", "nelson"]

Array = NDArray[np.float64]

#: Upper control limit factor of a moving range of span 2 (D4 = 1 + 3·d3/d2).
D4 = 3.267

#: What each Nelson rule tests, by number.
NELSON_RULES: dict[int, str] = {
    1: "one point beyond 3σ",
    2: "nine points in a row on one side of the centre line",
    3: "six points in a row steadily increasing or decreasing",
    4: "fourteen points in a row alternating up and down",
}


@dataclass(frozen=True)
class ChartLimits:
    """Limits of the individuals and moving-range charts (unit of the values).

    ``baseline`` is the number of values the limits were computed from.
    """

    center: float
    sigma: float
    ucl: float
    lcl: float
    mr_center: float
    mr_ucl: float
    baseline: int


@dataclass(frozen=True)
class Violation:
    """One Nelson-rule violation: the rule number and the points it covers (indices, inclusive)."""

    rule: int
    start: int
    end: int

    @property
    def points(self) -> range:
        return range(self.start, self.end + 1)


def moving_range(x: ArrayLike) -> Array:
    """|x_i − x_{i−1}| for i = 1 … n−1: shape (n−1,) for ``x`` of shape (n,)."""
    return np.abs(np.diff(np.asarray(x, dtype=float).ravel()))


def chart_limits(x: ArrayLike, baseline: int = 20) -> ChartLimits:
    """X and MR chart limits from the first ``baseline`` values of ``x`` (all of them when fewer).

    Parameters
    ----------
    x : array_like, shape (n,)
        Finite individual values in time order.
    baseline : int
        Size of the baseline window, at least 2.

    Raises
    ------
    ParameterError
        ``baseline`` below 2.
    """
    if baseline < 2:
        raise ParameterError(f"spc: the baseline must hold at least 2 parts, got {baseline}")
    values = np.asarray(x, dtype=float).ravel()[:baseline]
    if values.size < 2:
        return ChartLimits(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, int(values.size))
    center = float(values.mean())
    mr = float(moving_range(values).mean())
    sigma = mr / D2
    return ChartLimits(center, sigma, center + 3 * sigma, center - 3 * sigma, mr, D4 * mr, int(values.size))


def _runs(labels: NDArray[np.int64], length: int) -> list[tuple[int, int]]:
    """Maximal runs of one non-zero label at least ``length`` long: (first, last) indices, inclusive."""
    if labels.size == 0:
        return []
    change = np.flatnonzero(np.diff(labels) != 0) + 1
    starts = np.r_[0, change]
    ends = np.r_[change - 1, labels.size - 1]
    keep = (labels[starts] != 0) & (ends - starts + 1 >= length)
    return list(zip(starts[keep].tolist(), ends[keep].tolist(), strict=True))


def nelson(x: ArrayLike, center: float, sigma: float, rules: tuple[int, ...] = (1, 2, 3, 4)) -> list[Violation]:
    """Nelson rules 1–4 on ``x`` against a centre line and σ.

    Parameters
    ----------
    x : array_like, shape (n,)
        Finite values in time order.
    center, sigma : float
        Centre line and σ of the chart (:class:`ChartLimits`); rules 1 and 2 are not
        tested when either is not finite (or σ ≤ 0 for rule 1).
    rules : tuple of int
        Which rules to test.

    Returns
    -------
    list of Violation
        Ordered by rule, then by first point.
    """
    values = np.asarray(x, dtype=float).ravel()
    found: list[Violation] = []
    known = math.isfinite(center) and math.isfinite(sigma)
    if 1 in rules and known and sigma > 0:
        found += [Violation(1, i, i) for i in np.flatnonzero(np.abs(values - center) > 3 * sigma).tolist()]
    if 2 in rules and known:
        side = np.sign(values - center).astype(np.int64)
        found += [Violation(2, s, e) for s, e in _runs(side, 9)]
    step = np.sign(np.diff(values)).astype(np.int64)
    if 3 in rules:  # five equal-signed steps = six points
        found += [Violation(3, s, e + 1) for s, e in _runs(step, 5)]
    if 4 in rules and step.size >= 2:
        # flip[j]: steps j and j+1 go opposite ways; twelve flips in a row = thirteen steps = fourteen points
        flip = ((step[:-1] * step[1:]) < 0).astype(np.int64)
        found += [Violation(4, s, e + 2) for s, e in _runs(flip, 12)]
    return found
