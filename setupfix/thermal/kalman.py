"""Scalar Kalman filter fusing lumped-mass predictions with sensor readings (Wang 2017, eqs. (5)–(9)).

Procedural :func:`predict` / :func:`update` work element-wise on numpy arrays, so the
same two functions run one sensor in a controller loop, all sensors of a machine at
once, or a whole GA population of noise ratios at once.  :class:`FusionFilter` is the
thin streaming wrapper (filterpy naming: ``x_prior``, ``P_prior``, ``x_post``,
``P_post``, ``K``): O(1) work per sample and sensor.

Only the ratio ``q = N / R`` of the process and measurement variances shapes the
estimates: multiplying ``N``, ``R`` and ``P0`` by one constant leaves every gain and
every estimate unchanged, so the GA searches ``log10 q`` with ``R = 1`` (notes §5).

Sensor failure (Wang 2017, §5): a reading that jumps by more than ``jump`` from the
previous reading, or is missing (NaN), gets gain 0 — the fused value is then the
lumped-mass prediction alone.  A jump latches the sensor as failed until
:meth:`FusionFilter.reset`; a broken PT100 rarely recovers by itself.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["predict", "update", "steady_state", "fuse", "FusionFilter"]

Array = npt.NDArray[np.float64]


def predict(
    x_post: npt.ArrayLike,
    P_post: npt.ArrayLike,
    A: npt.ArrayLike,
    B: npt.ArrayLike,
    ambient: npt.ArrayLike,
    c: npt.ArrayLike,
    N: npt.ArrayLike,
) -> tuple[Array, Array]:
    """Prediction stage, eqs. (5)–(6).

    ``T_P = A T_F + B T_e + C`` and ``P_P = A² P_F + N`` (element-wise, broadcasting).

    Parameters
    ----------
    x_post, P_post : array_like
        Fused temperature (°C) and its variance at the previous sample.
    A, B : array_like
        Lumped-mass coefficients (eq. (5)).
    ambient : array_like
        Environment temperature T_e at this sample (°C).
    c : array_like
        Heat input term ``C n^j`` at this sample (°C).
    N : array_like
        Process-noise variance (°C²).

    Returns
    -------
    x_prior, P_prior : ndarray
    """
    A = np.asarray(A, dtype=float)
    x_prior = (
        A * np.asarray(x_post, dtype=float)
        + np.asarray(B, dtype=float) * np.asarray(ambient, dtype=float)
        + np.asarray(c, dtype=float)
    )
    P_prior = A * A * P_post + N
    return np.asarray(x_prior, dtype=float), np.asarray(P_prior, dtype=float)


def update(
    x_prior: npt.ArrayLike, P_prior: npt.ArrayLike, z: npt.ArrayLike, R: npt.ArrayLike, use: npt.ArrayLike = True
) -> tuple[Array, Array, Array]:
    """Update stage, eqs. (7)–(9), with gain forced to 0 where ``use`` is False.

    ``K = P_P / (P_P + R)``, ``T_F = T_P + K (T_M − T_P)``, ``P_F = P_P − K P_P``.

    Parameters
    ----------
    x_prior, P_prior : array_like
    z : array_like
        Measured temperature T_M (°C); ignored where ``use`` is False.
    R : array_like
        Measurement-noise variance (°C²).
    use : array_like of bool
        False for a failed or missing reading (gain 0, Wang 2017 §4–5).

    Returns
    -------
    x_post, P_post, K : ndarray
    """
    x_prior = np.asarray(x_prior, dtype=float)
    P_prior = np.asarray(P_prior, dtype=float)
    K = np.where(use, P_prior / (P_prior + R), 0.0)
    innovation = np.where(use, np.asarray(z, dtype=float) - x_prior, 0.0)
    return x_prior + K * innovation, P_prior - K * P_prior, K


def steady_state(A: npt.ArrayLike, N: npt.ArrayLike, R: npt.ArrayLike = 1.0) -> tuple[Array, Array]:
    """Closed-form steady state of eqs. (6)–(9): prior variance and gain.

    The fixed point of ``P = A² P R / (P + R) + N`` is the positive root of
    ``P² + (R(1 − A²) − N) P − N R = 0``::

        P∞ = [N − R(1 − A²) + sqrt((R(1 − A²) − N)² + 4 N R)] / 2,   K∞ = P∞ / (P∞ + R).

    Returns
    -------
    P_prior_inf, K_inf : ndarray
    """
    A, N, R = (np.asarray(v, dtype=float) for v in (A, N, R))
    b = R * (1.0 - A * A) - N
    P = 0.5 * (-b + np.sqrt(b * b + 4.0 * N * R))
    return P, P / (P + R)


def fuse(
    measured: npt.ArrayLike,
    ambient: npt.ArrayLike,
    A: npt.ArrayLike,
    B: npt.ArrayLike,
    C: npt.ArrayLike,
    q: npt.ArrayLike,
    *,
    jump: float = np.inf,
    p0: float = 1.0,
    x0: npt.ArrayLike | None = None,
) -> tuple[Array, Array]:
    """Run the filter over a whole log: fused temperatures and gains.

    Vectorised over sensors and over candidate parameter sets (the trailing axes of
    ``A``, ``B``, ``q`` broadcast against the sensor axis of ``measured``); the loop
    runs over time only.

    Parameters
    ----------
    measured : array_like, shape (n, S)
        Sensor temperatures T_M (°C); NaN for a missing reading.
    ambient : array_like, shape (n,)
    A, B : array_like, broadcastable to (..., S)
    C : array_like, shape (..., S, n)
        Heat input per sample.
    q : array_like, broadcastable to (..., S)
        Ratio N / R (R = 1).
    jump : float
        Reading change (°C per sample) taken as a sensor failure.
    p0 : float
        Initial variance relative to R.
    x0 : array_like, optional
        Initial temperature; default the first reading (the ambient where missing).

    Returns
    -------
    fused : ndarray, shape (..., n, S)
    gain : ndarray, shape (..., n, S)
    """
    Tm = np.asarray(measured, dtype=float)
    Tm = Tm.reshape(Tm.shape[0], -1)
    te = np.asarray(ambient, dtype=float)
    C = np.asarray(C, dtype=float)
    n = Tm.shape[0]
    A = np.asarray(A, dtype=float)
    shape = np.broadcast_shapes(A.shape, np.shape(B), np.shape(q), C.shape[:-1], (Tm.shape[1],))
    if x0 is None:
        x0 = np.where(np.isfinite(Tm[0]), Tm[0], te[0])
    x = np.broadcast_to(np.asarray(x0, dtype=float), shape).copy()
    P = np.full(shape, float(p0))
    failed = np.zeros(shape, dtype=bool)
    fused = np.empty((*shape[:-1], n, shape[-1]))
    gain = np.zeros_like(fused)
    fused[..., 0, :] = x
    prev = Tm[0]
    Cn = np.broadcast_to(C, (*shape, n))
    for j in range(1, n):
        z = Tm[j]
        ok = np.isfinite(z)
        failed = failed | (ok & np.isfinite(prev) & (np.abs(z - np.where(np.isfinite(prev), prev, z)) > jump))
        x, P = predict(x, P, A, B, te[j], Cn[..., j], q)
        x, P, K = update(x, P, np.where(ok, z, 0.0), 1.0, ok & ~failed)
        fused[..., j, :] = x
        gain[..., j, :] = K
        prev = np.where(ok, z, prev)
    return fused, gain


class FusionFilter:
    """Streaming fusion of S sensors: one :meth:`step` per sample, O(S) work.

    Parameters
    ----------
    A, B : array_like, shape (S,)
        Lumped-mass coefficients of each sensor (eq. (5)).
    q : array_like, shape (S,)
        N / R of each sensor.
    jump : float
        Reading change (°C per sample) taken as a sensor failure.
    p0 : float
        Initial variance relative to R.

    Attributes
    ----------
    x_prior, P_prior, x_post, P_post, K : ndarray, shape (S,)
        State after the last call, filterpy naming.
    failed : ndarray of bool, shape (S,)
        Sensors latched as failed.
    """

    def __init__(
        self, A: npt.ArrayLike, B: npt.ArrayLike, q: npt.ArrayLike, *, jump: float = np.inf, p0: float = 1.0
    ) -> None:
        self.A = np.asarray(A, dtype=float)
        self.B = np.asarray(B, dtype=float)
        self.q = np.asarray(q, dtype=float)
        self.jump = float(jump)
        self.p0 = float(p0)
        self.x_post: Array | None = None
        self.reset()

    def reset(self, x0: npt.ArrayLike | None = None) -> None:
        """Forget the state; the next :meth:`step` starts from its reading (or ``x0``)."""
        size = self.A.shape
        self.x_post = None if x0 is None else np.broadcast_to(np.asarray(x0, dtype=float), size).copy()
        self.P_post = np.full(size, self.p0)
        self.x_prior = np.full(size, np.nan)
        self.P_prior = np.full(size, np.nan)
        self.K = np.zeros(size)
        self.failed = np.zeros(size, dtype=bool)
        self._prev = np.full(size, np.nan)

    def step(self, measured: npt.ArrayLike, ambient: float, c: npt.ArrayLike) -> Array:
        """Fuse one sample and return the fused temperatures, shape (S,).

        Parameters
        ----------
        measured : array_like, shape (S,)
            Readings (NaN where missing).
        ambient : float
            Environment temperature (°C).
        c : array_like, shape (S,)
            Heat input term ``C n^j`` of each sensor at this sample.
        """
        z = np.asarray(measured, dtype=float)
        ok = np.isfinite(z)
        if self.x_post is None:  # first sample: start from the reading, as :func:`fuse` does
            self.x_post = np.where(ok, z, ambient).astype(float)
            self._prev = np.where(ok, z, np.nan)
            return self.x_post.copy()
        jumped = ok & np.isfinite(self._prev) & (np.abs(z - np.nan_to_num(self._prev)) > self.jump)
        self.failed |= jumped
        self.x_prior, self.P_prior = predict(self.x_post, self.P_post, self.A, self.B, ambient, c, self.q)
        self.x_post, self.P_post, self.K = update(
            self.x_prior, self.P_prior, np.where(ok, z, 0.0), 1.0, ok & ~self.failed
        )
        self._prev = np.where(ok, z, self._prev)
        return self.x_post.copy()
