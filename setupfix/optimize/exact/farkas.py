"""Farkas certificates by NNLS: weights proving that no point of the box meets rows G k ≤ b, or a point.

Units as in :mod:`setupfix.optimize.exact.session` (grid steps).  The least-distance problem
min Σ c k² s.t. G k ≤ b, k in the box, solved through NNLS (Lawson & Hanson 1974, ch. 23;
:func:`~setupfix.optimize.exact.grid.nnls_least_distance`), has two outcomes: a residual with a
non-zero last entry gives its point (continuous — a point to round; nothing is proved by it),
and a zero residual gives row weights y ≥ 0 that this module checks in numpy, whatever NNLS's
tolerances: with w = Gᵀy, ``max over the box of Σ y_j (b_j − G_j k) = yᵀb + Σ_i max(−w_i kmin_i,
−w_i kmax_i) < 0`` proves that no k in the box meets the rows.  With integer rows rounded at a
level (:func:`~setupfix.optimize.exact.grid.rounded_rhs`) that is a proof about grid points too,
which is what the leximin levels use (:mod:`setupfix.optimize.exact.leximin.level`).

A certificate rarely needs the rows far from the point it is sought at: given that point, the
rows and box limits within ``NEAR`` steps of it are tried first — a subsystem with no point
proves that the whole one has none — and the whole system answers where that does not prove
it.  On the paper-size reports the near columns are a third of the system and hold a
certificate in 838 of 846 level proofs (``bench/point_tests.py``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from setupfix.optimize.exact.session import GridRows

__all__ = ["NEAR", "checked_weights", "farkas_or_point", "nnls_solve"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: Rows and box limits within this many steps of the given point are where :func:`farkas_or_point` first seeks
#: a certificate [steps].
NEAR = 2.0


def farkas_or_point(
    rows: GridRows, b: Array, k: Array | None = None, whole: bool = True
) -> tuple[Array | None, Array | None]:
    """Row weights y ≥ 0 (sum 1) proving that no k in the box meets G k ≤ b; else the least Σ c k² point.

    From the NNLS least-distance system (:func:`~setupfix.optimize.exact.grid.nnls_least_distance`): its
    Farkas side, the proof checked here (``max over the box of Σ y_j (b_j − G_j k) < 0``), or its
    point (continuous, a point to round; nothing is proved by it).  (None, None): NNLS did not decide.

    ``k``, a grid point near the rows (the level's own point): the certificate is first sought among the
    rows and box limits within ``NEAR`` steps of k — a subsystem with no point proves the whole one
    has none, and NNLS on a third of the columns costs a third (``bench/point_tests.py``); the whole
    system answers when that does not prove it, and always gives the point.  ``whole=False`` (with k):
    the near rows only — (None, None) where they prove nothing (NNLS on every column of a shop-size
    system costs more: 0.26 s at 180 × 2,000 against 0.03 s near k, ``bench/results/leximin_shop_trace.txt``).
    """
    n = rows.n_free
    keep = np.isfinite(b)
    n_rows = int(keep.sum())
    _, e = rows.nnls_system(keep)
    e = e.copy()
    e[-1, :n_rows] = -b[keep]
    e[-1, n_rows : n_rows + n] = rows.kmin
    e[-1, n_rows + n :] = -rows.kmax
    if k is not None:
        near = np.flatnonzero(np.concatenate(((b - rows.g_rows @ k)[keep], k - rows.kmin, rows.kmax - k)) <= NEAR)
        if 0 < near.size < e.shape[1]:
            sub = nnls_solve(e[:, near])
            if sub is not None and abs(sub[1][-1]) <= 1e-9:
                u = np.zeros(e.shape[1])
                u[near] = sub[0]
                y = checked_weights(rows, b, keep, u[:n_rows])
                if y is not None:
                    return y, None
        if not whole:
            return None, None
    out = nnls_solve(e)
    if out is None:
        return None, None
    u, r = out
    if abs(r[-1]) > 1e-9:  # the residual's last entry is not 0: a point exists
        return None, -r[:n] / r[-1] / np.sqrt(rows.cost)
    return checked_weights(rows, b, keep, u[:n_rows]), None


def nnls_solve(e: Array) -> tuple[Array, Array] | None:
    """u = NNLS(E, e_last) and the residual E u − e_last; None at NNLS's iteration limit."""
    f = np.zeros(e.shape[0])
    f[-1] = 1.0
    try:
        u, _ = _nnls()(e, f, maxiter=50 * e.shape[1])
    except RuntimeError:
        return None
    return u, e @ u - f


def checked_weights(rows: GridRows, b: Array, keep: Mask, u_rows: Array) -> Array | None:
    """The weights u on the finite rows, normalised, if they prove G k ≤ b empty over the box (else None)."""
    total = float(u_rows.sum())
    if total <= 0:
        return None
    y = np.zeros(b.size)
    y[keep] = u_rows / total
    w = y @ rows.g_rows
    worst = float(y[keep] @ b[keep] + np.maximum(-w * rows.kmin, -w * rows.kmax).sum())
    return y if worst < -1e-9 else None


@functools.cache
def _nnls() -> Callable[..., tuple[Array, float]]:
    """scipy's NNLS, imported on first use (``import setupfix`` stays light; the exact optimiser imports
    scipy.optimize before its clock starts)."""
    from scipy.optimize import nnls

    solve: Callable[..., tuple[Array, float]] = nnls
    return solve
