"""What a setup correction explains: leave-one-out fits of the registers to the measured deviations.

A deviation beyond the reject band is either *gross* — a broken tool, a bad
measurement, a wrong part: nothing the setup registers do explains it — or a *setup
error*: a register entered wrong (a WKS off by 0.35 mm shifts every dimension of its
station), which the other dimensions reveal.  The test is the dimension's residual after
the best correction fitted to the **other** dimensions (the registers fitted by least
squares to bring every other dimension to the middle of its tolerance): a dimension
whose residual is still beyond the reject band is gross; one brought inside it is
explained, and the fit's register changes say which register looks wrong by how much.

The fit is ridge least squares, min ‖r + Cᵀx‖² + λ‖x‖² (r the deviations from the
tolerance middle, C the composite of eqs. 3–4, λ tiny: a register no other dimension
sees stays at 0), and its leave-one-out residuals come in closed form,
e_q / (1 − H_qq) with H = Cᵀ(CCᵀ + λI)⁻¹C (the hat matrix), one solve for all dimensions.
A setup error is usually one register entered wrong, and the least-squares fit spreads its
change over every register that moves the same dimensions (a WKS and the tools of its
station); :func:`one_register` finds the single register that explains the dimensions
best, which is named when it alone explains them.  Pure: arrays in, arrays out.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["targets", "fit_registers", "one_register", "leave_one_out"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: Ridge weight relative to the mean squared register column (keeps registers no dimension sees at 0).
RIDGE = 1e-9


def targets(lower: Array, upper: Array) -> Array:
    """The value each dimension is fitted to: its tolerance middle (one-sided: the finite limit's side of 0).

    lower, upper : ndarray of shape (m,) [unit] → ndarray of shape (m,)
    """
    lo, up = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    mid = (lo + up) / 2
    out: Array = np.where(np.isfinite(mid), mid, np.clip(0.0, lo, up))
    return out


def _system(composite: Array) -> tuple[Array, float]:
    c = np.asarray(composite, dtype=float)
    gram = c @ c.T
    scale = float(np.trace(gram)) / max(c.shape[0], 1)
    lam = RIDGE * (scale if scale > 0 else 1.0)
    return gram + lam * np.eye(c.shape[0]), lam


def fit_registers(composite: Array, residual: Array, use: Mask | None = None) -> Array:
    """Register changes x that bring the used dimensions closest to their targets: min ‖r + Cᵀx‖² + λ‖x‖².

    Parameters
    ----------
    composite : ndarray of shape (n, m)
        C of eqs. 3–4 (register j moves dimension q by C[j, q] per unit).
    residual : ndarray of shape (m,) [unit]
        Deviation minus target (:func:`targets`).
    use : bool ndarray of shape (m,), optional
        Dimensions that enter the fit (default all).

    Returns
    -------
    x : ndarray of shape (n,) [unit]
        The correction; the register "looks off" by −x.
    """
    c = np.asarray(composite, dtype=float)
    r = np.asarray(residual, dtype=float)
    if use is not None:
        c, r = c[:, use], r[use]
    if c.shape[0] == 0:
        return np.zeros(0)
    a, _ = _system(c)
    return -np.linalg.solve(a, c @ r)


def one_register(composite: Array, residual: Array, use: Mask | None = None) -> tuple[int, float, Array]:
    """The one register whose change alone brings the used dimensions closest to their targets.

    For each register j the best change a_j = −Σ C[j, q] r_q / Σ C[j, q]² (least squares
    over the used dimensions q); the register with the least sum of squared residuals wins.

    Parameters
    ----------
    composite : ndarray of shape (n, m)
    residual : ndarray of shape (m,) [unit]
        Deviation minus target.
    use : bool ndarray of shape (m,), optional
        Dimensions that enter the fit (default all).

    Returns
    -------
    j : int
        The register (−1 when no register moves a used dimension).
    change : float [unit]
        Its change a_j (the register "looks off" by −a_j).
    after : ndarray of shape (m,) [unit]
        Every dimension's residual r + C[j]·a_j.
    """
    c = np.asarray(composite, dtype=float)
    r = np.asarray(residual, dtype=float)
    mask = np.ones(r.size, bool) if use is None else np.asarray(use, bool)
    cu, ru = c[:, mask], r[mask]
    norms = np.sum(cu * cu, axis=1)
    if c.shape[0] == 0 or not np.any(norms > 0):
        return -1, 0.0, r.copy()
    change = np.where(norms > 0, -(cu @ ru) / np.where(norms > 0, norms, 1.0), 0.0)
    sse = np.sum((ru[None, :] + cu * change[:, None]) ** 2, axis=1)
    j = int(np.argmin(np.where(norms > 0, sse, np.inf)))
    after: Array = r + c[j] * change[j]
    return j, float(change[j]), after


def leave_one_out(composite: Array, residual: Array) -> Array:
    """Each dimension's residual after the correction fitted to all the others (closed form).

    Parameters
    ----------
    composite : ndarray of shape (n, m)
    residual : ndarray of shape (m,) [unit]
        Deviation minus target.

    Returns
    -------
    ndarray of shape (m,) [unit]
        r_q + C[:, q]·x₋q with x₋q = :func:`fit_registers` on every dimension but q:
        e_q / (1 − H_qq), e = r + Cᵀx the residual of the fit on all dimensions.
    """
    c = np.asarray(composite, dtype=float)
    r = np.asarray(residual, dtype=float)
    if c.shape[0] == 0:
        return r.copy()
    a, _ = _system(c)
    solved = np.linalg.solve(a, c)  # (n, m): A⁻¹C
    x = -solved @ r
    e = r + c.T @ x
    leverage = np.einsum("jq,jq->q", c, solved)  # H_qq
    out: Array = e / np.maximum(1.0 - leverage, 1e-15)
    return out
