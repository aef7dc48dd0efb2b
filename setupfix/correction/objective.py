"""Objective functions of the setup-correction problem (Stryczek 2014, eqs. 5–10).

All functions are vectorised: deviations may carry leading population axes.
Dimensions whose deviation is NaN (absent from the report) are ignored.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["margins", "error_budget", "correction_norm", "fitness", "F1_WEIGHT"]

Array = npt.NDArray[np.float64]

#: Weight of f1 in the substitute objective f = 10·f1 − f2 (eq. 10).
F1_WEIGHT = 10.0


def margins(deviation: Array, lower: Array, upper: Array) -> Array:
    """Distance of each deviation to its nearer tolerance limit.

    The per-dimension form of eqs. 5–6: with the tolerance zone [lower, upper]
    (signed deviations from nominal) the margin is min(dev − lower, upper − dev),
    which for a symmetric zone ±T/2 equals T/2 − |dev|.  Negative when the
    dimension is out of tolerance.  A one-sided tolerance has an infinite limit.

    Parameters
    ----------
    deviation : ndarray of shape (..., n_dimensions) [model unit]
    lower, upper : ndarray of shape (n_dimensions,) [model unit]

    Returns
    -------
    ndarray of shape (..., n_dimensions) [model unit]
    """
    dev = np.asarray(deviation, dtype=np.float64)
    return np.minimum(dev - lower, upper - dev)


def error_budget(deviation: Array, lower: Array, upper: Array) -> Array:
    """Unilateral error budget δ = f1: the smallest margin of all dimensions (eq. 8).

    Parameters
    ----------
    deviation : ndarray of shape (..., n_dimensions) [model unit]
        NaN entries (dimensions not measured) are ignored.
    lower, upper : ndarray of shape (n_dimensions,) [model unit]

    Returns
    -------
    ndarray of shape (...) [model unit]
        Negative when some dimension is out of tolerance.
    """
    m = margins(deviation, lower, upper)
    worst: Array = np.min(np.where(np.isnan(m), np.inf, m), axis=-1)
    return worst


def correction_norm(x: Array) -> Array:
    """f2: Euclidean norm of the correction vector (eq. 9).

    Parameters
    ----------
    x : ndarray of shape (..., n_registers) [model unit]

    Returns
    -------
    ndarray of shape (...) [model unit]
    """
    norm: Array = np.sqrt(np.sum(np.square(x), axis=-1))
    return norm


def fitness(f1: npt.ArrayLike, f2: npt.ArrayLike) -> Array:
    """Substitute single objective f = 10·f1 − f2 (eq. 10), to be maximised."""
    return F1_WEIGHT * np.asarray(f1, dtype=np.float64) - np.asarray(f2, dtype=np.float64)
