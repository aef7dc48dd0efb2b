"""Grey prediction models GM(1,N) and GMC(1,N) as pure numpy functions.

Conventions (Abdulshahed et al. 2017, §2.2; Tien 2012): ``y`` is the target series
:math:`x_1^{(0)}` of length ``n`` (the thermal error), ``X`` the driver series
:math:`x_2^{(0)} … x_N^{(0)}` as an array of shape ``(n, N-1)`` (temperatures).
Time is counted in samples: the development coefficient ``b1`` is "per sample",
so a model is only valid for logs with the sampling interval it was fitted on.
Parameter vectors are ``theta = [b1, b2, …, bN, u]`` (length ``N + 1``) for GMC(1,N)
and ``[b1, b2, …, bN]`` for the classic GM(1,N), which has no control constant.

The time response of GMC(1,N) is a convolution integral, approximated by the
trapezoid rule.  Two discretisations are in use and they do not give the same
numbers, so both are offered and named:

``"trapezoid"``
    Abdulshahed et al. (2017) eq. (2): the composite trapezoid of
    :math:`\\int_1^k e^{-b_1(k-s)} f(s)\\,ds` on the integer nodes.
``"tien"``
    Tien (2012): one trapezoid per interval, weighted by the exponential at the
    interval's midpoint, :math:`\\sum_{\\tau=2}^k e^{-b_1(k-\\tau+1/2)}\\tfrac12[f(\\tau)+f(\\tau-1)]`.

Both are evaluated as the first-order recursion ``C(k) = e^{-b1} C(k-1) + f(k)``
through :func:`scipy.signal.lfilter`: a direct sum would cost O(n²) per
evaluation, and the cuckoo search needs thousands of evaluations.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.signal import lfilter

__all__ = [
    "ResponseForm",
    "ago",
    "iago",
    "background",
    "lag_drivers",
    "gmc_design",
    "gmc_least_squares",
    "gmc_response",
    "gmc_predict",
    "gm1n_design",
    "gm1n_least_squares",
    "gm1n_response",
    "gm1n_predict",
]

Array = npt.NDArray[np.float64]
ResponseForm = Literal["trapezoid", "tien"]


def ago(x: npt.ArrayLike) -> Array:
    """First-order accumulated generating operation (1-AGO) along axis 0.

    Parameters
    ----------
    x : array_like, shape (n,) or (n, p)
        Raw series :math:`x^{(0)}`.

    Returns
    -------
    ndarray, same shape
        :math:`x^{(1)}(k) = \\sum_{j \\le k} x^{(0)}(j)` (Abdulshahed 2017, §2.2).
    """
    return np.cumsum(np.asarray(x, dtype=float), axis=0)


def iago(x1: npt.ArrayLike) -> Array:
    """Inverse AGO along the last axis: :math:`\\hat x^{(0)}(k) = \\hat x^{(1)}(k) - \\hat x^{(1)}(k-1)`.

    The first element is kept as it is (Abdulshahed 2017, last step of §2.2).

    Parameters
    ----------
    x1 : array_like, shape (..., n)

    Returns
    -------
    ndarray, shape (..., n)
    """
    x1 = np.asarray(x1, dtype=float)
    out = np.empty_like(x1)
    out[..., :1] = x1[..., :1]
    out[..., 1:] = np.diff(x1, axis=-1)
    return out


def background(x1: npt.ArrayLike) -> Array:
    """Background values :math:`z^{(1)}(k) = \\tfrac12[x^{(1)}(k) + x^{(1)}(k-1)]`, k = 2…n.

    Parameters
    ----------
    x1 : array_like, shape (n,) or (n, p)

    Returns
    -------
    ndarray, shape (n - 1,) or (n - 1, p)
    """
    x: Array = np.asarray(x1, dtype=np.float64)
    return 0.5 * (x[1:] + x[:-1])


def lag_drivers(X: npt.ArrayLike, delay: int) -> Array:
    """Shift the drivers by ``delay`` samples: row k holds :math:`x_j^{(0)}(k - r)`.

    This is the delay ``r`` of Abdulshahed (2017) eq. (1), written with the drivers
    moved instead of the target so that the output stays aligned with the log.
    The first ``r`` rows repeat the first sample (the machine is taken to have been
    at its initial state before the log began).

    Parameters
    ----------
    X : array_like, shape (n, p)
    delay : int, >= 0

    Returns
    -------
    ndarray, shape (n, p)
    """
    X = np.asarray(X, dtype=float)
    if delay < 0:
        raise ValueError("delay must be >= 0")
    if delay == 0 or X.shape[0] == 0:
        return X.copy()
    pad = np.repeat(X[:1], min(delay, X.shape[0]), axis=0)
    return np.concatenate([pad, X[: max(X.shape[0] - delay, 0)]], axis=0)


# --------------------------------------------------------------------------- GMC(1,N)


def gmc_design(y: npt.ArrayLike, X: npt.ArrayLike) -> tuple[Array, Array]:
    """Least-squares system of the GMC(1,N) grey equation.

    The grey equation :math:`x_1^{(0)}(k) + b_1 z_1^{(1)}(k) = \\sum_j b_j z_j^{(1)}(k) + u`,
    k = 2…n (discretised eq. (1) of Abdulshahed 2017; Tien 2012) gives rows
    ``[-z1(k), z2(k), …, zN(k), 1]`` and right-hand side ``x1(k)``.

    Parameters
    ----------
    y : array_like, shape (n,)
    X : array_like, shape (n, N-1)

    Returns
    -------
    B : ndarray, shape (n-1, N+1)
    Y : ndarray, shape (n-1,)
    """
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float).reshape(len(y), -1)
    z1 = background(ago(y))
    zj = background(ago(X))
    B = np.column_stack([-z1, zj, np.ones_like(z1)])
    return B, y[1:]


def gmc_least_squares(y: npt.ArrayLike, X: npt.ArrayLike) -> Array:
    """GMC(1,N) coefficients ``[b1, b2…bN, u]`` by least squares on the grey equation.

    Uses :func:`numpy.linalg.lstsq` (SVD) rather than the normal equations
    :math:`(B^TB)^{-1}B^TY`: the AGOs of temperatures that all rise together are
    nearly collinear and the normal equations lose half the digits.

    Parameters
    ----------
    y : array_like, shape (n,), n >= 3
    X : array_like, shape (n, N-1)

    Returns
    -------
    ndarray, shape (N+1,)
    """
    B, Y = gmc_design(y, X)
    theta, *_ = np.linalg.lstsq(B, Y, rcond=None)
    return np.asarray(theta, dtype=float)


def _convolve_exp(f: Array, decay: Array) -> Array:
    """``C[p, k] = sum_{h<=k} decay[p]**(k-h) * f[p, h]`` for each row p (IIR recursion)."""
    out = np.empty_like(f)
    for p in range(f.shape[0]):
        out[p] = lfilter([1.0], [1.0, -decay[p]], f[p])
    return out


def gmc_response(
    theta: npt.ArrayLike, y0: float | npt.ArrayLike, X1: npt.ArrayLike, form: ResponseForm = "trapezoid"
) -> Array:
    """Time response :math:`\\hat x_1^{(1)}(k)` of GMC(1,N), k = 1…n.

    Abdulshahed et al. (2017) eq. (2) (``form="trapezoid"``)::

        x1(1) e^{-b1(k-1)} + ½ e^{-b1(k-1)} f(1) + Σ_{τ=2}^{k-1} e^{-b1(k-τ)} f(τ) + ½ f(k)

    or Tien's (2012) midpoint-weighted form (``form="tien"``), with
    :math:`f(\\tau) = \\sum_{j=2}^N b_j x_j^{(1)}(\\tau) + u`.  Both give
    :math:`\\hat x_1^{(1)}(1) = x_1^{(0)}(1)`.

    Parameters
    ----------
    theta : array_like, shape (N+1,) or (P, N+1)
        ``[b1, b2…bN, u]``; a 2-D array evaluates P parameter sets at once.
    y0 : float or array_like, shape (P,)
        Initial value :math:`x_1^{(0)}(1)` of the target.
    X1 : array_like, shape (n, N-1)
        AGO of the drivers (already lagged by the delay r).
    form : {"trapezoid", "tien"}

    Returns
    -------
    ndarray, shape (n,) or (P, n)
        AGO of the predicted target, in the target's unit × samples.
    """
    theta = np.asarray(theta, dtype=float)
    single = theta.ndim == 1
    theta = np.atleast_2d(theta)
    X1 = np.asarray(X1, dtype=float)
    X1 = X1.reshape(X1.shape[0], -1)
    n = X1.shape[0]
    b1 = theta[:, 0]
    f = theta[:, 1:-1] @ X1.T + theta[:, -1:]  # (P, n)
    k = np.arange(n, dtype=float)  # k - 1 for 1-based k
    with np.errstate(over="ignore"):
        decay_k = np.exp(-np.outer(b1, k))  # (P, n)
        decay = np.exp(-b1)
    y0 = np.broadcast_to(np.asarray(y0, dtype=float), b1.shape)
    if form == "trapezoid":
        conv = _convolve_exp(f, decay) - 0.5 * decay_k * f[:, :1] - 0.5 * f
    elif form == "tien":
        g = 0.5 * (f[:, 1:] + f[:, :-1])  # g(τ), τ = 2…n
        conv = np.zeros_like(f)
        if n > 1:
            with np.errstate(over="ignore"):
                conv[:, 1:] = np.exp(-0.5 * b1)[:, None] * _convolve_exp(g, decay)
    else:
        raise ValueError(f"unknown response form {form!r}")
    x1hat: Array = y0[:, None] * decay_k + conv
    return x1hat[0] if single else x1hat


def gmc_predict(
    theta: npt.ArrayLike,
    y0: float | npt.ArrayLike,
    X: npt.ArrayLike,
    *,
    delay: int = 0,
    form: ResponseForm = "trapezoid",
) -> Array:
    """Predicted target :math:`\\hat x_1^{(0)}` from raw drivers: lag, 1-AGO, eq. (2), IAGO.

    Parameters
    ----------
    theta : array_like, shape (N+1,) or (P, N+1)
    y0 : float
        Target value at the first sample (0 for an error measured from a cold start).
    X : array_like, shape (n, N-1)
        Raw drivers (temperatures or temperature rises).
    delay : int
        Delay r in samples between the drivers and the target (eq. (1)).
    form : {"trapezoid", "tien"}

    Returns
    -------
    ndarray, shape (n,) or (P, n)
    """
    X1 = ago(lag_drivers(np.asarray(X, dtype=float).reshape(np.shape(X)[0], -1), delay))
    return iago(gmc_response(theta, y0, X1, form))


# --------------------------------------------------------------------------- classic GM(1,N)


def gm1n_design(y: npt.ArrayLike, X: npt.ArrayLike) -> tuple[Array, Array]:
    """Least-squares system of the classic GM(1,N): rows ``[-z1(k), x2^(1)(k), …, xN^(1)(k)]``.

    Unlike GMC(1,N) the drivers enter with their AGO values, not background values,
    and there is no control constant (Tien 2012; notes §4.2).

    Returns
    -------
    B : ndarray, shape (n-1, N)
    Y : ndarray, shape (n-1,)
    """
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float).reshape(len(y), -1)
    B = np.column_stack([-background(ago(y)), ago(X)[1:]])
    return B, y[1:]


def gm1n_least_squares(y: npt.ArrayLike, X: npt.ArrayLike) -> Array:
    """Classic GM(1,N) coefficients ``[b1, b2…bN]`` by least squares (SVD)."""
    B, Y = gm1n_design(y, X)
    theta, *_ = np.linalg.lstsq(B, Y, rcond=None)
    return np.asarray(theta, dtype=float)


def gm1n_response(theta: npt.ArrayLike, y0: float, X1: npt.ArrayLike) -> Array:
    """Classic GM(1,N) time response, which treats the driving sum as constant.

    :math:`\\hat x_1^{(1)}(k) = [x_1^{(0)}(1) - S(k)/b_1] e^{-b_1(k-1)} + S(k)/b_1`,
    :math:`S(k) = \\sum_j b_j x_j^{(1)}(k)`.  Tien (2012) shows this is biased for
    forecasting; it is kept for comparison.

    Parameters
    ----------
    theta : array_like, shape (N,) or (P, N)
    y0 : float
    X1 : array_like, shape (n, N-1)

    Returns
    -------
    ndarray, shape (n,) or (P, n)
    """
    theta = np.asarray(theta, dtype=float)
    single = theta.ndim == 1
    theta = np.atleast_2d(theta)
    X1 = np.asarray(X1, dtype=float)
    X1 = X1.reshape(X1.shape[0], -1)
    b1 = theta[:, :1]
    S = theta[:, 1:] @ X1.T
    k = np.arange(X1.shape[0], dtype=float)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        x1hat: Array = (y0 - S / b1) * np.exp(-b1 * k) + S / b1
    return x1hat[0] if single else x1hat


def gm1n_predict(theta: npt.ArrayLike, y0: float, X: npt.ArrayLike, *, delay: int = 0) -> Array:
    """Predicted target of the classic GM(1,N) from raw drivers (lag, AGO, response, IAGO)."""
    X1 = ago(lag_drivers(np.asarray(X, dtype=float).reshape(np.shape(X)[0], -1), delay))
    return iago(gm1n_response(theta, y0, X1))
