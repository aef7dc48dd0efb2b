"""Multivariate regression (MRA) of the thermal error on temperature rises.

Wang et al. (2017) eq. (16): ``E^j = Σ_i β_i ΔT_i^j`` on the raw measured rises, the
baseline of both papers; eq. (10)–(11) is the same regression on fused rises.  Solved
by :func:`numpy.linalg.lstsq` (SVD): temperature rises are strongly collinear, and the
normal equations ``(ΔTᵀΔT)⁻¹ΔTᵀE`` of eq. (11) would square their condition number.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["rises", "reference_state", "rises_from", "mra_fit", "mra_predict"]

Array = npt.NDArray[np.float64]


def rises(T: npt.ArrayLike) -> Array:
    """Temperature rises ΔT from the first sample, shape of ``T`` ((n,) or (..., n, S) along axis -2).

    A NaN first reading is replaced by the first finite one of that column.
    """
    T = np.asarray(T, dtype=float)
    if T.ndim == 1:
        T = T[:, None]
    finite = np.isfinite(T)
    first_idx = np.argmax(finite, axis=-2)
    first: Array = np.take_along_axis(T, np.expand_dims(first_idx, -2), axis=-2)
    return T - first


def reference_state(T: npt.ArrayLike) -> Array:
    """Reference temperatures of a log: the first finite reading of each sensor.

    Parameters
    ----------
    T : array_like, shape (n, S)
        Temperatures (°C) or rises (K); NaN for a missing reading.

    Returns
    -------
    ndarray, shape (S,)
        NaN only for a sensor that never reads.
    """
    T = np.asarray(T, dtype=float)
    T = T.reshape(T.shape[0], -1)
    first = np.argmax(np.isfinite(T), axis=0)
    return np.asarray(T[first, np.arange(T.shape[1])], dtype=float)


def rises_from(T: npt.ArrayLike, reference: npt.ArrayLike) -> Array:
    """Temperature rises ΔT = T − T_ref from a stored reference state (Wang 2017 eq. (10)).

    Parameters
    ----------
    T : array_like, shape (..., n, S)
    reference : array_like, shape (S,)

    Returns
    -------
    ndarray, shape of ``T``
    """
    return np.asarray(T, dtype=np.float64) - np.asarray(reference, dtype=np.float64)


def mra_fit(dT: npt.ArrayLike, E: npt.ArrayLike, *, intercept: bool = False) -> Array:
    """Least-squares β of eq. (11)/(16).

    Parameters
    ----------
    dT : array_like, shape (n, S)
        Temperature rises (K).
    E : array_like, shape (n,)
        Measured thermal error.
    intercept : bool
        Add a constant β_0 (not in the paper; useful when the error is not zero at
        the start of the log).

    Returns
    -------
    ndarray, shape (S,) or (S + 1,) with β_0 last
    """
    X = np.asarray(dT, dtype=float)
    X = X.reshape(X.shape[0], -1)
    if intercept:
        X = np.column_stack([X, np.ones(X.shape[0])])
    beta: Array = np.linalg.lstsq(X, np.asarray(E, dtype=float), rcond=None)[0]
    return beta


def mra_predict(beta: npt.ArrayLike, dT: npt.ArrayLike) -> Array:
    """Predicted error ``ΔT β`` (eq. (10)/(16)); ``beta`` longer by one holds β_0 last.

    Parameters
    ----------
    beta : array_like, shape (S,) or (S + 1,)
    dT : array_like, shape (..., n, S)

    Returns
    -------
    ndarray, shape (..., n)
    """
    beta = np.asarray(beta, dtype=float)
    dT = np.asarray(dT, dtype=float)
    S = dT.shape[-1]
    out: Array = dT @ beta[:S]
    return out + beta[S] if beta.size > S else out
