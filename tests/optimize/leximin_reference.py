"""An independent lexicographic max–min solver for the tests: scipy.optimize.milp, stage by stage.

The leximin order of sorted margins equals the lexicographic order of the prefix sums
S_p = (sum of the p smallest margins), p = 1 … m: if two sorted vectors first differ at
position p, their prefix sums agree before p and differ in the same direction at p.  Each S_p is
concave and has the linear form S_p(k) = max_{r, s ≥ 0} p·r − Σ_q s_q with s_q ≥ r − M_q(k), and
M_q(k) = min_{j ∈ q} margin_j(k) (a zone: the least of its facets, or of a fine polygon of its
circle).  Stage p maximises S_p holding S_1 … S_{p−1} at their optima (less ``tol``) on the
integer grid.  Nothing here is setupfix's code: rows come in as plain arrays.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from scipy.sparse import csr_array, hstack, vstack


def lexicographic_maxmin(
    a: np.ndarray,
    b: np.ndarray,
    row_dim: np.ndarray,
    n_dims: int,
    kmin: np.ndarray,
    kmax: np.ndarray,
    stages: int | None = None,
    tol: float = 1e-6,
    time_limit: float = 120.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Lexicographically maximal sorted margins over integer k in [kmin, kmax].

    Parameters
    ----------
    a, b : margin_j(k) = b_j − a_j · k, shapes (r, n) and (r,)
        (one variable u_q ≤ each margin of q stands for M_q: every S_p grows with each M_q, so this is exact)
    row_dim : dimension of each row, shape (r,)
    stages : how many smallest positions to fix (default all n_dims)

    Returns
    -------
    (the optimal prefix sums S_1 … S_stages, a grid point reaching them)
    """
    r, n = a.shape
    stages = n_dims if stages is None else stages
    # columns: k (n, integer) | u (n_dims): u_q ≤ every margin of q | per stage i: r_i, s_i (n_dims ≥ 0)
    one_hot = csr_array((np.ones(r), (np.arange(r), row_dim)), shape=(r, n_dims))
    eye = csr_array(np.eye(n_dims))
    blocks: list[tuple[int, float]] = []  # (p, S_p*) fixed so far
    k_best = np.zeros(n)
    sums = []
    for p in range(1, stages + 1):
        nb = len(blocks) + 1
        width = n + n_dims + nb * (1 + n_dims)
        rows = [hstack([csr_array(a), one_hot, csr_array((r, width - n - n_dims))])]  # a_j k + u_q ≤ b_j
        lo, hi = [np.full(r, -np.inf)], [b]
        for i in range(nb):  # r_i − s_iq − u_q ≤ 0
            off = n + n_dims + i * (1 + n_dims)
            rows.append(
                hstack(
                    [
                        csr_array((n_dims, n)),
                        -eye,
                        csr_array((n_dims, off - n - n_dims)),
                        csr_array(np.ones((n_dims, 1))),
                        -eye,
                        csr_array((n_dims, width - off - 1 - n_dims)),
                    ]
                )
            )
            lo.append(np.full(n_dims, -np.inf))
            hi.append(np.zeros(n_dims))
        for i, (pp, s_star) in enumerate(blocks):  # p_i r_i − Σ s_i ≥ S_i* − tol
            off = n + n_dims + i * (1 + n_dims)
            row = np.zeros(width)
            row[off] = pp
            row[off + 1 : off + 1 + n_dims] = -1.0
            rows.append(csr_array(row[None, :]))
            lo.append(np.array([s_star - tol]))
            hi.append(np.array([np.inf]))
        off = n + n_dims + len(blocks) * (1 + n_dims)
        cost = np.zeros(width)
        cost[off] = -p
        cost[off + 1 : off + 1 + n_dims] = 1.0
        lower, upper = np.zeros(width), np.full(width, np.inf)
        lower[:n], upper[:n] = kmin, kmax
        lower[n : n + n_dims] = -np.inf
        for i in range(nb):
            lower[n + n_dims + i * (1 + n_dims)] = -np.inf  # r_i is free
        integrality = np.zeros(width)
        integrality[:n] = 1
        res = milp(
            cost,
            constraints=LinearConstraint(vstack(rows).tocsr(), np.concatenate(lo), np.concatenate(hi)),
            integrality=integrality,
            bounds=Bounds(lower, upper),
            options={"mip_rel_gap": 0, "time_limit": time_limit},
        )
        assert res.status == 0, res.message
        s_p = float(-res.fun)
        blocks.append((p, s_p))
        sums.append(s_p)
        k_best = np.rint(res.x[:n])
    return np.array(sums), k_best


def prefix_sums(margins: np.ndarray) -> np.ndarray:
    """S_1 … S_m of a margin vector (sorted ascending, cumulated)."""
    return np.cumsum(np.sort(margins))
