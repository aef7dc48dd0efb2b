"""Accuracy measures of the two papers, all on residuals ``e − ê`` along the last axis.

* RMSE (Abdulshahed 2017, Table II) — root mean square of the residuals;
* RMSV (Wang 2017, eq. (13)) — the same with ``n − 1`` in the denominator;
* maximum residual MR (Wang 2017, eq. (17)) — ``max |e − ê|``;
* efficiency E (Abdulshahed 2017, Table II) — Nash–Sutcliffe ``1 − Σ(e − ê)² / Σ(e − ē)²``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["rmse", "rmsv", "max_residual", "efficiency", "Scores", "score"]

Array = npt.NDArray[np.float64]


def _residual(measured: npt.ArrayLike, predicted: npt.ArrayLike) -> Array:
    return np.asarray(measured, dtype=np.float64) - np.asarray(predicted, dtype=np.float64)


def rmse(measured: npt.ArrayLike, predicted: npt.ArrayLike) -> Array:
    """sqrt(mean((e − ê)²)), target unit."""
    r = _residual(measured, predicted)
    out: Array = np.sqrt(np.mean(r * r, axis=-1))
    return out


def rmsv(measured: npt.ArrayLike, predicted: npt.ArrayLike) -> Array:
    """sqrt(Σ(e − ê)² / (n − 1)), Wang (2017) eq. (13)."""
    r = _residual(measured, predicted)
    out: Array = np.sqrt(np.sum(r * r, axis=-1) / max(r.shape[-1] - 1, 1))
    return out


def max_residual(measured: npt.ArrayLike, predicted: npt.ArrayLike) -> Array:
    """max |e − ê|, Wang (2017) eq. (17)."""
    out: Array = np.max(np.abs(_residual(measured, predicted)), axis=-1)
    return out


def efficiency(measured: npt.ArrayLike, predicted: npt.ArrayLike) -> Array:
    """Nash–Sutcliffe efficiency 1 − Σ(e − ê)² / Σ(e − ē)² (1 is perfect, 0 is the mean).

    NaN where the measured error is constant (to rounding: its spread is below
    1e-20 of its mean square): E is undefined there, not a huge negative number.
    """
    e = np.asarray(measured, dtype=float)
    r = _residual(e, predicted)
    spread = np.sum((e - e.mean(axis=-1, keepdims=True)) ** 2, axis=-1)
    scale = np.sum(e * e, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = 1.0 - np.sum(r * r, axis=-1) / spread
        return np.where(spread > 1e-20 * scale, out, np.nan)


@dataclass(frozen=True)
class Scores:
    """The papers' measures for one prediction (target unit)."""

    rmse: float
    rmsv: float
    max_residual: float
    efficiency: float
    n: int

    def as_dict(self) -> dict[str, float | int]:
        return asdict(self)


def score(measured: npt.ArrayLike, predicted: npt.ArrayLike, *, skip_first: bool = True) -> Scores:
    """All measures of one 1-D prediction.

    ``skip_first`` drops the first sample: every model here reproduces it by
    construction (the GMC response starts at x1(1); the rise-based regressions are 0
    there), so counting it would flatter the scores (notes §4.3, pitfall 3).
    """
    e = np.asarray(measured, dtype=float).ravel()
    p = np.asarray(predicted, dtype=float).ravel()
    if skip_first and e.size > 1:
        e, p = e[1:], p[1:]
    return Scores(float(rmse(e, p)), float(rmsv(e, p)), float(max_residual(e, p)), float(efficiency(e, p)), int(e.size))
