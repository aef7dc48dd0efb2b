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


def lexicographic_maxmin(a: np.ndarray, b: np.ndarray, row_dim: np.ndarray, n_dims: int, kmin: np.ndarray,
                         kmax: np.ndarray, stages: int | None = None, tol: float = 1e-7,
                         time_limit: float = 120.0) -> tuple[np.ndarray, np.ndarray]:
    """Lexicographically maximal sorted margins over integer k in [kmin, kmax].

    Parameters
    ----------
    a, b : margin_j(k) = b_j − a_j · k, shapes (r, n) and (r,)
    row_dim : dimension of each row, shape (r,)
    stages : how many smallest positions to fix (default all n_dims)

    Returns
    -------
    (the optimal prefix sums S_1 … S_stages, a grid point reaching them)
    """
    r, n = a.shape
    stages = n_dims if stages is None else stages
    one_hot = csr_array((np.ones(r), (np.arange(r), row_dim)), shape=(r, n_dims))
    blocks: list[tuple[int, float]] = []  # (p, S_p*) fixed so far
    k_best = np.zeros(n)
    sums = []
    for p in range(1, stages + 1):
        width = n + (len(blocks) + 1) * (1 + n_dims)
        rows, lo, hi = [], [], []
        for i in range(len(blocks) + 1):
            off = n + i * (1 + n_dims)
            # s_q − r ≥ −margin_j ⇔ a_j k − r + s_q ≥ −b_j … written as  −a_j k + r − s_q ≤ b_j
            left = csr_array((r, off - n))
            right = csr_array((r, width - off - 1 - n_dims))
            rows.append(hstack([csr_array(-a), left, csr_array(np.ones((r, 1))), -one_hot, right]))
            lo.append(np.full(r, -np.inf))
            hi.append(b)
        for i, (pp, s_star) in enumerate(blocks):
            off = n + i * (1 + n_dims)
            row = np.zeros(width)
            row[off] = pp
            row[off + 1:off + 1 + n_dims] = -1.0
            rows.append(csr_array(row[None, :]))
            lo.append(np.array([s_star - tol]))
            hi.append(np.array([np.inf]))
        off = n + len(blocks) * (1 + n_dims)
        cost = np.zeros(width)
        cost[off] = -p
        cost[off + 1:off + 1 + n_dims] = 1.0
        lower = np.full(width, 0.0)
        upper = np.full(width, np.inf)
        lower[:n], upper[:n] = kmin, kmax
        for i in range(len(blocks) + 1):
            lower[n + i * (1 + n_dims)] = -np.inf  # r is free
        integrality = np.zeros(width)
        integrality[:n] = 1
        res = milp(cost, constraints=LinearConstraint(vstack(rows).tocsr(), np.concatenate(lo), np.concatenate(hi)),
                   integrality=integrality, bounds=Bounds(lower, upper),
                   options={"mip_rel_gap": 0, "time_limit": time_limit})
        assert res.status == 0, res.message
        s_p = float(-res.fun)
        blocks.append((p, s_p))
        sums.append(s_p)
        k_best = np.rint(res.x[:n])
    return np.array(sums), k_best


def prefix_sums(margins: np.ndarray) -> np.ndarray:
    """S_1 … S_m of a margin vector (sorted ascending, cumulated)."""
    return np.cumsum(np.sort(margins))
