"""Is a control chart's baseline a stable window, and which is the first one that is?

Control limits are only meaningful when the parts they come from were made by one
unchanged, in-control process (Montgomery, Introduction to Statistical Quality Control,
Phase I use of control charts).  A baseline fails that when

* a correction (or any split: a time the process was changed) falls between two of its
  parts: the limits then mix two processes;
* the baseline's own points break a Nelson rule against the limits computed from them
  (:func:`setupfix.spc.charts.nelson`).

The *first stable window* is the earliest run of ``baseline`` consecutive parts with no
split between any two of them and no Nelson rule (1–4) broken by its points against its
own limits.  A window that holds a split inside cannot be stable, so the search jumps to
the part after the split; otherwise it moves one part at a time.  The search stops after
:data:`MAX_WINDOWS` windows and says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from setupfix.core.errors import ParameterError
from setupfix.spc.charts import Violation, chart_limits, nelson

__all__ = ["BaselineCheck", "baseline_check", "first_stable_window", "MAX_WINDOWS"]

#: Windows the search for a stable one tries before it gives up (and says it did).
MAX_WINDOWS = 5000


@dataclass(frozen=True)
class BaselineCheck:
    """What is wrong with a baseline of ``size`` parts, and the first stable window.

    Attributes
    ----------
    size : int
        Parts in the baseline (the first ``size`` of the series).
    splits_inside : tuple of int
        Indices ``at`` of the splits inside the baseline: a split between part ``at − 1`` and ``at``,
        ``0 < at < size``.
    violations : tuple of Violation
        Nelson-rule violations of the baseline's points against its own limits.
    first_stable : int or None
        Index of the first part of the first stable window, ``None`` when none was found.
    searched : int
        Windows tried (``MAX_WINDOWS`` at most); when ``first_stable`` is None and ``searched``
        is ``MAX_WINDOWS`` the search stopped before the end of the series.
    longest_free : int
        The most consecutive parts of the series with no split between them (a baseline longer
        than this always spans a split).
    """

    size: int
    splits_inside: tuple[int, ...]
    violations: tuple[Violation, ...]
    first_stable: int | None
    searched: int
    longest_free: int

    @property
    def stable(self) -> bool:
        """True when the baseline spans no split and breaks no rule."""
        return not self.splits_inside and not self.violations


def _window_violations(values: np.ndarray, start: int, size: int) -> list[Violation]:
    window = values[start : start + size]
    limits = chart_limits(window, size)
    return nelson(window, limits.center, limits.sigma)


def first_stable_window(values: ArrayLike, size: int, splits: Sequence[int] = ()) -> tuple[int | None, int]:
    """The first window of ``size`` parts without a split inside and without a rule broken.

    Parameters
    ----------
    values : array_like, shape (n,)
        Finite individual values in time order.
    size : int
        Window length (the baseline), at least 2.
    splits : sequence of int
        Split indices ``at`` (a split between parts ``at − 1`` and ``at``).

    Returns
    -------
    (start, searched) : (int or None, int)
        The window's first index (None: none found) and the windows tried.
    """
    if size < 2:
        raise ParameterError(f"spc: the baseline must hold at least 2 parts, got {size}")
    x = np.asarray(values, dtype=float).ravel()
    cuts = np.unique(np.asarray(list(splits), dtype=np.int64))
    start, tried = 0, 0
    while start + size <= x.size and tried < MAX_WINDOWS:
        tried += 1
        inside = cuts[(cuts > start) & (cuts < start + size)]
        if inside.size:
            start = int(inside[-1])  # every window holding this split fails: begin right after it
            continue
        if not _window_violations(x, start, size):
            return start, tried
        start += 1
    return None, tried


def baseline_check(values: ArrayLike, size: int, splits: Sequence[int] = ()) -> BaselineCheck:
    """Check the baseline (the first ``size`` parts of ``values``) and find the first stable window.

    Parameters
    ----------
    values : array_like, shape (n,)
        Finite individual values in time order; fewer than ``size``: the baseline is all of them.
    size : int
        Baseline length, at least 2.
    splits : sequence of int
        Split indices ``at`` (corrections: the first part made after each).
    """
    if size < 2:
        raise ParameterError(f"spc: the baseline must hold at least 2 parts, got {size}")
    x = np.asarray(values, dtype=float).ravel()
    used = min(size, int(x.size))
    inside = tuple(sorted({int(a) for a in splits if 0 < a < used}))
    broken = tuple(_window_violations(x, 0, used)) if used >= 2 else ()
    edges = np.unique(np.r_[0, [int(a) for a in splits if 0 < a < x.size], x.size])
    longest = int(np.diff(edges).max()) if edges.size > 1 else int(x.size)
    if not inside and not broken:
        return BaselineCheck(used, inside, broken, 0, 1, longest)
    start, tried = first_stable_window(x, size, splits)
    return BaselineCheck(used, inside, broken, start, tried, longest)
