"""Tests of a candidate effect with the cycle (the part) as the unit of evidence.

Real parts vary as a whole: a part cut a little long is long on all its dimensions
(shared per-part variation, e.g. every tool offset a little each cycle).  The cells of
one cycle are then correlated and an F-test that counts every cell as independent
evidence calls that shared variation an effect.  Here every candidate is tested on
evidence counted per cycle:

* **time-dependent kinds** (drift, thermal, wear and every kind whose field changes
  between cycles) — a cluster-robust score test with the cycle as the cluster
  (a Wald test with the CR1 sandwich variance, Liang & Zeger 1986; small-sample
  degrees of freedom after Bell & McCaffrey 2002, Imbens & Kolesár 2016): with r the
  residual of the current model, z̃ the candidate's column residualised on it, the
  per-cycle scores s_k = Σ_q z̃_kq r_kq, w_k = Σ_q z̃_kq² and β̂ = Σ s_k / Σ w_k,

      T = (Σ_k s_k)² / (K/(K−1) · Σ_k (s_k − β̂ w_k)²)    ~  F(1, df),

  df = (Σ_k w_k)² / Σ_k w_k² − 1 (Satterthwaite / Kish effective number of cycles),
  capped at K − 1.  The sandwich variance holds whatever covariance
  the cells of one cycle share, and df shrinks when the column's leverage sits on few
  cycles (a saturating drift with a short time constant, a tool worn on few parts);
* **static kinds** (scale, position, group) — the same test when the dimensions keep
  no constant offsets beyond the cycle-to-cycle variation; otherwise against the lack
  of fit (:func:`lack_of_fit`, one value per dimension: the static pattern must
  explain the dimensions' offsets);
* **per-register sets** (one process channel on every tool, a coefficient each: q
  columns) — the multi-column form of the same test (:func:`cluster_wald`): with B an
  orthonormal basis of the residualised block, U = Bᵀr, per-cycle scores
  e_k = B_kᵀ(r_k − B_k U) and V = K/(K−1) Σ_k e_k e_kᵀ, the Wald statistic
  W = Uᵀ V⁺ U is referred to Hotelling's T² as F = W (df − q + 1)/(df q) ~ F(q, df − q + 1)
  (df the smallest effective number of cycles of the block's columns); q = 1 is the
  test above;
* **relations** (register i × dimension q, one cell per cycle) — the F-test on that
  dimension's own residual variance (K − 3 df), so a dimension that shares more of the
  per-part variation is not judged by the pooled noise of the others.

Series of fewer than four cycles have no cycle-level variance worth the name: their
candidates keep the cell-level F-test (:func:`cell_pvalue`), and the selection says so.

Calibration: ``bench/diagnose_calibration.py`` (no effect hidden, shared per-part noise
of 0.5–3× the cell noise: rate of any effect reported ≤ α within its binomial interval).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.stats

from setupfix.diagnose.fit import Fit, Observations
from setupfix.diagnose.support import STATIC
from setupfix.diagnose.terms import AXES, EffectSpec, Layout, Series, field_factors

__all__ = [
    "MIN_CYCLES",
    "cluster_test",
    "cluster_wald",
    "cell_pvalue",
    "dimension_pvalue",
    "lack_of_fit",
    "cycle_sums",
    "relation_set",
    "orth",
    "position_structure",
]

Array = npt.NDArray[np.float64]

_TINY = 1e-9

#: Fewest cycles for the cycle-level tests (below: cell-level F-test).
MIN_CYCLES = 4


def orth(X: Array) -> Array:
    """Orthonormal basis of the column space of X (SVD, tiny singular values dropped)."""
    if X.shape[1] == 0:
        return X
    u, s, _ = np.linalg.svd(X, full_matrices=False)
    keep = s > _TINY * max(1.0, float(s.max(initial=0.0)))
    out: Array = u[:, keep]
    return out


def cycle_sums(values: Array, cycle: npt.NDArray[np.intp], n_cycles: int) -> Array:
    """Per-cycle sums of the rows of ``values`` (N, m) → (n_cycles, m)."""
    if values.shape[0] and np.all(cycle[1:] >= cycle[:-1]):
        starts = np.flatnonzero(np.r_[True, cycle[1:] != cycle[:-1]])
        out = np.zeros((n_cycles, values.shape[1]))
        out[cycle[starts]] = np.add.reduceat(values, starts, axis=0)
        return out
    out = np.zeros((n_cycles, values.shape[1]))
    np.add.at(out, cycle, values)
    return out


def cluster_test(Zt: Array, r: Array, cycle: npt.NDArray[np.intp], n_cycles: int) -> tuple[Array, Array]:
    """Cluster-robust score test (cycle = cluster) of one-column candidates.

    Parameters
    ----------
    Zt : ndarray (N, m)
        Candidate columns residualised on the current model.
    r : ndarray (N,)
        Residual of the current model.
    cycle : ndarray of int (N,)
        Cycle of each cell.
    n_cycles : int

    Returns
    -------
    stat, p : ndarray (m,)
        T of the module text and its p-value (1 where the column is zero).
    """
    s = cycle_sums(Zt * r[:, None], cycle, n_cycles)
    w = cycle_sums(Zt * Zt, cycle, n_cycles)
    k = int(np.count_nonzero(w.sum(axis=1) > 0)) if w.size else 0
    u = s.sum(axis=0)
    wt = w.sum(axis=0)
    beta = u / np.where(wt > 0, wt, 1.0)
    e = s - beta[None, :] * w  # per-cycle scores of the residual with the candidate fitted
    v = np.einsum("km,km->m", e, e) * k / max(k - 1, 1)
    ww = np.einsum("km,km->m", w, w)
    ok = (v > 0) & (wt > 0) & (k >= 2)
    nu = np.where(ok, wt**2 / np.where(ok, ww, 1.0) - 1.0, 1.0)
    nu = np.clip(nu, 1.0, max(k - 1, 1))
    stat = np.where(ok, u**2 / np.where(ok, v, 1.0), 0.0)
    p = np.where(ok, scipy.stats.f.sf(stat, 1, nu), 1.0)
    return stat, p


def cluster_wald(
    Zt: Array, r: Array, cycle: npt.NDArray[np.intp], n_cycles: int, Q: Array | None = None, power: float = 0.5
) -> tuple[float, float, int]:
    """Cluster-robust Wald test (cycle = cluster) of a block of candidate columns (module text).

    Parameters
    ----------
    Zt : ndarray (N, q)
        The block's columns residualised on the current model.
    r : ndarray (N,)
        Residual of the current model.
    cycle : ndarray of int (N,)
    n_cycles : int
    Q : ndarray (N, p), optional
        Orthonormal basis of the current model.  Given, each cycle's residual with the block
        fitted is corrected for the cycle's leverage before it enters the variance,
        (I − H_kk)^(−power) e_k with H_kk the cycle's block of the hat matrix of the current
        model and the block (``power`` 0.5: the CR2 "bias-reduced linearisation" of Bell &
        McCaffrey 2002, unbiased under independent homoscedastic cells; 1: the jackknife, CR3).
        A test of few parts whose columns sit on few of them (a cell of a designed experiment)
        needs it: CR1 then underestimates the variance.  The degrees of freedom are then Bell and
        McCaffrey's (the Satterthwaite df of the corrected variance, the smallest over the block's
        columns) in place of the effective number of cycles.  Without ``Q``: CR1, K/(K−1).

    Returns
    -------
    F : float
        Hotelling-scaled statistic, W (df − q + 1) / (df q).
    p : float
        Its p-value on F(q, df − q + 1); 1 when the block is empty or the cycles too few.
    q : int
        Rank of the block.
    """
    B = orth(Zt)
    q = int(B.shape[1])
    if q == 0:
        return 0.0, 1.0, 0
    u = B.T @ r  # (q,): Σ_k s_k with B orthonormal (β̂ = u)
    s = cycle_sums(B * r[:, None], cycle, n_cycles)  # (K, q)
    gram = cycle_sums(np.einsum("ni,nj->nij", B, B).reshape(B.shape[0], q * q), cycle, n_cycles)
    gram = gram.reshape(n_cycles, q, q)
    seen = gram.reshape(n_cycles, -1).any(axis=1)
    k = int(seen.sum())
    w = np.einsum("kii->ki", gram)  # per-cycle weight of each column
    wt, ww = w.sum(axis=0), np.einsum("ki,ki->i", w, w)
    nu = float(np.clip(np.min(wt**2 / np.where(ww > 0, ww, 1.0)) - 1.0, 1.0, max(k - 1, 1)))
    if Q is None:
        e = s - np.einsum("kij,j->ki", gram, u)
        V = (e.T @ e) * k / max(k - 1, 1)
    else:
        e, nu_bm = _leverage_scores(B, Q, r - B @ u, cycle, power)
        V = e.T @ e
        nu = float(np.clip(nu_bm, 1.0, max(k - 1, 1)))
    df2 = nu - q + 1
    if k < 2 or df2 < 1:
        return 0.0, 1.0, q
    stat = float(u @ np.linalg.pinv(V, rcond=1e-12, hermitian=True) @ u)
    f = stat * df2 / (nu * q)
    return f, float(scipy.stats.f.sf(f, q, df2)), q


def _leverage_scores(B: Array, Q: Array, e: Array, cycle: npt.NDArray[np.intp], power: float) -> tuple[Array, float]:
    """Per-cycle scores B_kᵀ A_k e_k, A_k = (I − H_kk)^(−power), H_kk = Q_k Q_kᵀ + B_k B_kᵀ (:func:`cluster_wald`),
    shape (K_seen, q), and the Bell–McCaffrey degrees of freedom of the variance: per column c of B the
    Satterthwaite df of Σ_k (a_kcᵀ e_k)² under independent homoscedastic cells, with e = (I − H) ε,
    (tr GGᵀ)² / ‖GGᵀ‖²_F, GGᵀ = W Wᵀ − (WQ)(WQ)ᵀ − (WB)(WB)ᵀ, W (K × N) holding a_kc on cycle k's rows;
    the smallest over the columns."""
    order = np.argsort(cycle, kind="stable")
    cuts = np.flatnonzero(np.diff(cycle[order])) + 1
    groups = np.split(order, cuts)
    q = B.shape[1]
    scores = np.zeros((len(groups), q))
    ww = np.zeros((len(groups), q))
    wq = np.zeros((q, len(groups), Q.shape[1]))
    wb = np.zeros((q, len(groups), q))
    for k, rows in enumerate(groups):
        H = Q[rows] @ Q[rows].T + B[rows] @ B[rows].T
        w, v = np.linalg.eigh(np.eye(rows.size) - H)
        a = v @ ((np.clip(w, 1e-6, None) ** -power)[:, None] * (v.T @ B[rows]))  # A_k B_k, (n_k, q)
        scores[k] = a.T @ e[rows]
        ww[k] = np.einsum("ic,ic->c", a, a)
        wq[:, k] = a.T @ Q[rows]
        wb[:, k] = a.T @ B[rows]
    df = np.inf
    for c in range(q):
        G = np.diag(ww[:, c]) - wq[c] @ wq[c].T - wb[c] @ wb[c].T
        norm = float(np.sum(G * G))
        if norm > 0:
            df = min(df, float(np.trace(G)) ** 2 / norm)
    return scores, df


def cell_pvalue(gain: float, rss0: float, df0: int, k: int) -> float:
    """Nested F-test counting cells (Seber & Lee §4.3): ΔRSS = ``gain`` on ``k`` columns."""
    df1 = df0 - k
    if df1 <= 0:
        return 1.0
    rss1 = max(rss0 - gain, 1e-300)
    return float(scipy.stats.f.sf((gain / k) / (rss1 / df1), k, df1))


def dimension_pvalue(gain: float, r_q: Array, k: int) -> float:
    """F-test of ``k`` columns acting on one dimension against that dimension's residual (one cell per cycle)."""
    df1 = r_q.size - 1 - k
    if df1 <= 0:
        return 1.0
    rss1 = max(float(r_q @ r_q) - gain, 1e-300)
    return float(scipy.stats.f.sf((gain / k) / (rss1 / df1), k, df1))


def lack_of_fit(dim: npt.NDArray[np.intp], r: Array, n: int, n_static: int, alpha: float) -> tuple[float, int] | None:
    """(SS, df) of the per-dimension mean residuals when they exceed the cycle-to-cycle noise, else None.

    The classic lack-of-fit test with the cycles as replicates: SS_lof = Σ_q n_q r̄_q²
    on (dimensions − static parameters) df against the pure error Σ (r − r̄_q)².
    """
    n_q = np.bincount(dim)
    seen = n_q > 0
    mean_q = np.bincount(dim, weights=r)[seen] / n_q[seen]
    ss_lof = float(np.sum(n_q[seen] * mean_q**2))
    ss_pure = float(r @ r) - ss_lof
    df_lof = int(seen.sum()) - n_static
    df_pure = n - int(seen.sum())
    if df_lof <= 1 or df_pure <= 1 or ss_pure <= 0:
        return None
    p = float(scipy.stats.f.sf((ss_lof / df_lof) / (ss_pure / df_pure), df_lof, df_pure))
    return (ss_lof, df_lof) if p < alpha else None


def relation_set(
    Q: Array, r: Array, obs: Observations, applied: Array, layout: Layout, spec: EffectSpec, alpha: float
) -> tuple[str, ...]:
    """Other registers the data cannot tell from the chosen one as the source of a relation effect.

    The dimension q answers register i's corrections: z_q ≈ c + δ u_i.  Register j stays
    a candidate unless the data reject "j alone" (c + δ_j u_j) in favour of both
    (c + δ_i u_i + δ_j u_j): the encompassing F-test (Seber & Lee, §4.3; 1 and N − p − 3 df)
    at ``alpha`` divided by the number of moved registers (Bonferroni over the register that
    could have been chosen), so the set holds the true register with probability ≥ 1 − α.
    A register never moved on q has u_j constant: "j alone" is the constant, which stays a
    candidate when the slope on u_i is not significant — registers that moved together
    (proportionally) always stay together.

    Returns
    -------
    tuple of str
        ``relation: q ~ j`` for every register j in the set but i, in register order.
    """
    q = layout.dimension_ids.index(str(spec.dimension))
    i = layout.register_ids.index(str(spec.register))
    rows = obs.dim == q
    n_r = applied.shape[1]
    M = np.zeros((obs.n, n_r + 1))
    M[rows, :n_r] = applied[obs.cycle[rows]]
    M[rows, n_r] = 1.0
    P = M - Q @ (Q.T @ M)
    rss0 = float(r @ r)
    df = obs.n - Q.shape[1] - 3
    if df <= 0:
        return tuple(f"relation: {spec.dimension} ~ {rid}" for j, rid in enumerate(layout.register_ids) if j != i)

    def rss(cols: list[int]) -> float:
        B = orth(P[:, cols])
        t = B.T @ r
        return rss0 - float(t @ t)

    moved = np.ptp(applied[np.unique(obs.cycle[rows])], axis=0) > _TINY
    m = max(int(moved.sum()), 1)
    out = []
    for j in range(n_r):
        if j == i:
            continue
        both = rss([i, j, n_r])
        gain = rss([j, n_r]) - both
        p = float(scipy.stats.f.sf(gain / max(both / df, 1e-300), 1, df)) if gain > 0 else 1.0
        if p * m >= alpha:
            out.append(f"relation: {spec.dimension} ~ {layout.register_ids[j]}")
    return tuple(out)


def position_structure(layout: Layout, series: Series, fit: Fit, alpha: float) -> str | None:
    """A lack-of-fit note when the residual still follows the dimensions' positions (None otherwise).

    The dimensions' mean residuals r̄_q (over the cycles, weight n_q) are regressed on the
    linear displacement field a point can have in the plane of the measured axes: for every
    measuring axis a with at least three dimensions and every coordinate b spread over them,
    the column n_q[a] · x_q[b] (x-errors ∝ x and ∝ y, y-errors ∝ x and ∝ y: scales, rotation,
    shear), residualised on the fit's dimension-level columns (the setup state and the static
    effects).  F-test of that block against the rest of the offsets' scatter (Seber & Lee §4.3,
    k and D − r − k df, D the dimensions measured, r the fitted dimension-level rank) at ``alpha``.
    Multi-axis models only (one-axis dimensions have no measuring direction).
    """
    if layout.direction.shape[0] != layout.n_dimensions:
        return None
    res = fit.residual
    seen = np.isfinite(res)
    n_q = seen.sum(axis=0).astype(float)
    used = n_q > 0
    m = np.where(seen, res, 0.0).sum(axis=0)[used] / n_q[used]
    w = np.sqrt(n_q[used])
    direction = np.nan_to_num(layout.direction[used])
    coord = layout.coord[used]
    cols = []
    for a in range(3):
        along = np.abs(direction[:, a]) > 0.5
        if along.sum() < 3:
            continue
        for b in range(3):
            x = coord[along, b]
            if np.isfinite(x).all() and np.ptp(x) > 0:
                cols.append(direction[:, a] * np.nan_to_num(coord[:, b]))
    if not cols:
        return None
    model = [fit.basis.T[used]]
    for spec in fit.specs:
        if spec.kind in STATIC:
            factors = field_factors(spec, layout, series)
            if factors is not None:
                model.append(factors[1][used, None])
    Q = orth(np.hstack(model) * w[:, None])
    G = np.column_stack(cols) * w[:, None]
    B = orth(G - Q @ (Q.T @ G))
    k = int(B.shape[1])
    r = m * w
    r = r - Q @ (Q.T @ r)
    df2 = int(used.sum()) - int(Q.shape[1]) - k
    if k == 0 or df2 < 3:
        return None
    gain = float(np.sum((B.T @ r) ** 2))
    rest = max(float(r @ r) - gain, 1e-300)
    f = (gain / k) / (rest / df2)
    p = float(scipy.stats.f.sf(f, k, df2))
    if p >= alpha:
        return None
    axes = "/".join(AXES[a].upper() for a in range(3) if (np.abs(direction[:, a]) > 0.5).sum() >= 3)
    return (
        f"lack of fit against position: the residual still follows the features' coordinates along {axes} "
        f"(F = {f:.3g} on {k} and {df2} df, p = {p:.2g}): a deformation the effects found do not explain "
        "(a rotation or scale not modelled, a shear, a bent part)"
    )
