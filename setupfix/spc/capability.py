"""Process capability of individual measurements: Cp, Cpk (σ within), Pp, Ppk (σ overall).

For a series ``x`` of n individual values (one per part) and specification limits
LSL, USL (either may be absent, NaN):

* σ within  = MR̄ / d2, with MR̄ the mean moving range |x_i − x_{i−1}| and d2 = 1.128,
  the expected range of two independent standard normal values (moving ranges of
  span two);
* σ overall = the sample standard deviation (divisor n − 1);
* Cp = (USL − LSL) / 6σ_within, Cpk = min(USL − x̄, x̄ − LSL) / 3σ_within;
  Pp and Ppk the same with σ overall (NIST/SEMATECH e-Handbook of Statistical
  Methods, section 6.1.6, for the definitions).  With one limit only, Cp and Pp are
  undefined (NaN) and Cpk, Ppk are the one-sided index of the limit given.

The 95 % confidence interval of Cpk is Bissell's normal approximation (A. F. Bissell,
"How reliable is your capability index?", Applied Statistics 39 (1990) 331–340;
also Montgomery, Introduction to Statistical Quality Control, eq. 8.19):

    Ĉpk · (1 ± z_{1−α/2} · sqrt(1 / (9 n Ĉpk²) + 1 / (2 (n − 1))))

i.e. Ĉpk ± z · sqrt(1/(9n) + Ĉpk²/(2(n−1))).

Below :data:`MIN_PARTS` values a Cpk is flagged *too few parts* (:attr:`Capability.too_few`):
the approximation is rough there and the interval wide (at Ĉpk = 1.33 and n = 30 the 95 %
interval is already ±0.36; at n = 5 and Ĉpk = 13 it is ±8).  The number is this project's
choice, stated wherever the flag is shown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from numpy.typing import ArrayLike, NDArray

from setupfix.core.errors import ParameterError

__all__ = [
    "D2",
    "MIN_PARTS",
    "Capability",
    "capability",
    "cpk_interval",
    "sigma_within",
    "sigma_overall",
    "split_capability",
]

Array = NDArray[np.float64]

#: Expected range of two independent standard normal values (moving range of span 2).
D2 = 1.128

#: Fewer values than this: a capability index is shown as "too few parts" (see the module docstring).
MIN_PARTS = 30


def _finite(x: ArrayLike) -> Array:
    values: Array = np.asarray(x, dtype=np.float64).ravel()
    return values[np.isfinite(values)]


def sigma_within(x: ArrayLike) -> float:
    """σ within of individual values: mean moving range / d2.

    Parameters
    ----------
    x : array_like, shape (n,)
        Values in time order (any length unit); NaN entries are left out first.

    Returns
    -------
    float
        σ within in the unit of ``x``; NaN for fewer than two values.
    """
    values = _finite(x)
    if values.size < 2:
        return math.nan
    return float(np.mean(np.abs(np.diff(values))) / D2)


def sigma_overall(x: ArrayLike) -> float:
    """Sample standard deviation (divisor n − 1) of ``x`` (shape (n,)); NaN for fewer than two values."""
    values = _finite(x)
    return float(np.std(values, ddof=1)) if values.size >= 2 else math.nan


def _indices(mean: float, sigma: float, lower: float, upper: float) -> tuple[float, float]:
    """(C, Ck) for one σ: (USL − LSL)/6σ and min(USL − mean, mean − LSL)/3σ, NaN where undefined."""
    if not (math.isfinite(sigma) and sigma > 0):
        return math.nan, math.nan
    both = math.isfinite(lower) and math.isfinite(upper)
    spread = (upper - lower) / (6 * sigma) if both else math.nan
    sides = [
        s
        for s, ok in (
            ((upper - mean) / (3 * sigma), math.isfinite(upper)),
            ((mean - lower) / (3 * sigma), math.isfinite(lower)),
        )
        if ok
    ]
    return spread, (min(sides) if sides else math.nan)


def cpk_interval(cpk: float, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided confidence interval of Cpk by Bissell's approximation (see the module docstring).

    Parameters
    ----------
    cpk : float
        The estimate Ĉpk.
    n : int
        Number of values it was computed from.
    confidence : float
        Confidence level in (0, 1), default 0.95.

    Returns
    -------
    (low, high) : tuple of float
        NaN, NaN when Ĉpk is not finite or n < 2.
    """
    if not math.isfinite(cpk) or n < 2:
        return math.nan, math.nan
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    half = z * math.sqrt(1.0 / (9.0 * n) + cpk * cpk / (2.0 * (n - 1)))
    return cpk - half, cpk + half


@dataclass(frozen=True)
class Capability:
    """Capability of one series against its limits (lengths in the unit of the values).

    Attributes
    ----------
    n : int
        Values used (finite ones).
    mean, sigma_within, sigma_overall : float
        x̄, MR̄/d2 and the sample standard deviation.
    cp, cpk, pp, ppk : float
        The indices (NaN where undefined: one-sided limits for Cp/Pp, σ = 0, n < 2).
    cpk_low, cpk_high : float
        The 95 % confidence interval of Cpk (Bissell).
    out_of_tolerance : int
        Values below LSL or above USL.
    lower, upper : float
        The limits used (NaN: none on that side).
    """

    n: int
    mean: float
    sigma_within: float
    sigma_overall: float
    cp: float
    cpk: float
    pp: float
    ppk: float
    cpk_low: float
    cpk_high: float
    out_of_tolerance: int
    lower: float
    upper: float

    @property
    def too_few(self) -> bool:
        """True below :data:`MIN_PARTS` values: the indices are shown, flagged "too few parts"."""
        return self.n < MIN_PARTS


def capability(x: ArrayLike, lower: float, upper: float, *, confidence: float = 0.95) -> Capability:
    """Cp, Cpk, Pp, Ppk, σ within and overall, the Cpk interval and the count out of tolerance.

    Parameters
    ----------
    x : array_like, shape (n,)
        Individual values in time order (NaN entries left out).
    lower, upper : float
        Specification limits in the unit of ``x``; NaN for none on that side.
    confidence : float
        Level of the Cpk interval.
    """
    values = _finite(x)
    n = int(values.size)
    mean = float(values.mean()) if n else math.nan
    s_within, s_overall = sigma_within(values), sigma_overall(values)
    cp, cpk = _indices(mean, s_within, lower, upper)
    pp, ppk = _indices(mean, s_overall, lower, upper)
    low, high = cpk_interval(cpk, n, confidence)
    below = values < lower if math.isfinite(lower) else np.zeros(n, dtype=bool)
    above = values > upper if math.isfinite(upper) else np.zeros(n, dtype=bool)
    return Capability(
        n,
        mean,
        s_within,
        s_overall,
        cp,
        cpk,
        pp,
        ppk,
        low,
        high,
        int(np.count_nonzero(below | above)),
        float(lower),
        float(upper),
    )


def split_capability(x: ArrayLike, after: ArrayLike, lower: float, upper: float) -> tuple[Capability, Capability]:
    """Capability of the values before and after a split (a correction applied between them).

    Parameters
    ----------
    x : array_like, shape (n,)
        Values in time order.
    after : array_like of bool, shape (n,)
        True for the values made after the split.
    lower, upper : float
        Specification limits (NaN: none).

    Returns
    -------
    (before, after) : tuple of Capability
    """
    values = np.asarray(x, dtype=float).ravel()
    mask = np.asarray(after, dtype=bool).ravel()
    if mask.shape != values.shape:
        raise ParameterError(f"split: mask has shape {mask.shape}, values {values.shape}")
    return capability(values[~mask], lower, upper), capability(values[mask], lower, upper)
