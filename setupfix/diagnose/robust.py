"""Cluster-robust covariance of least-squares coefficients, the part (cycle) as the cluster.

Real parts vary as a whole, so the cells of one part share an error and the plain
σ²(XᵀX)⁻¹ understates the uncertainty of every coefficient whose column changes between
parts (a drift, a wear, a process channel) — about three times under shared per-part noise
of twice the cell noise.  The sandwich variance with the part as the cluster holds whatever
covariance the cells of one part share (Liang & Zeger 1986); its small-sample form CR2, the
"bias-reduced linearisation" of Bell & McCaffrey (2002, eq. 3.3; Pustejovsky & Tipton 2018),
corrects each part's residual for the part's leverage:

    V_CR2 = (XᵀX)⁺ [Σ_k X_kᵀ A_k e_k e_kᵀ A_k X_k] (XᵀX)⁺,   A_k = (I − H_kk)^(−1/2),

with e_k the residuals of part k, H_kk = X_k (XᵀX)⁺ X_kᵀ its block of the hat matrix.  It is
unbiased when the cells are in fact independent and homoscedastic.  Written on the thin SVD
X = U S Vᵀ: H_kk = U_k U_kᵀ and V_CR2 = V S⁻¹ [Σ_k U_kᵀ A_k e_k e_kᵀ A_k U_k] S⁻¹ Vᵀ.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["cr2_covariance"]

Array = npt.NDArray[np.float64]

#: Smallest eigenvalue of I − H_kk taken as such (a part whose cells a coefficient fits exactly).
_FLOOR = 1e-6


def cr2_covariance(u: Array, inv_s: Array, vt: Array, resid: Array, cluster: npt.NDArray[np.intp]) -> Array:
    """CR2 covariance of the least-squares coefficients (module text).

    Parameters
    ----------
    u : ndarray (N, r)
        Left singular vectors of X kept (rank r).
    inv_s : ndarray (r,)
        Their inverse singular values.
    vt : ndarray (r, p)
        Right singular vectors kept.
    resid : ndarray (N,) [unit of the response]
        Least-squares residuals.
    cluster : ndarray of int (N,)
        Cluster (part) of each row.

    Returns
    -------
    ndarray (p, p) [unit² / unit of the columns²]
        V_CR2; the pseudo-inverse's null space carries zero variance.
    """
    r = u.shape[1]
    order = np.argsort(cluster, kind="stable")
    cuts = np.flatnonzero(np.diff(cluster[order])) + 1
    meat = np.zeros((r, r))
    for rows in np.split(order, cuts):
        uk = u[rows]  # (n_k, r)
        w, v = np.linalg.eigh(np.eye(rows.size) - uk @ uk.T)
        a = v @ ((np.clip(w, _FLOOR, None) ** -0.5) * (v.T @ resid[rows]))  # A_k e_k
        g = uk.T @ a  # (r,)
        meat += np.outer(g, g)
    left = vt.T * inv_s  # V S⁻¹, (p, r)
    out: Array = left @ meat @ left.T
    return out
