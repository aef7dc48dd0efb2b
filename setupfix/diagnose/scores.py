"""What each candidate explains and its per-cycle test: the arrays the forward selection ranks.

One-column candidates are scored together (:func:`dense_scores`: ΔRSS of each column
residualised on the current model), relation candidates from per-dimension sums
without forming their N-row columns (:func:`relation_scores`), per-register process sets
as blocks (:func:`tested_sets`; an accepted set keeps the members that earn their coefficient,
:func:`prune_set`).  Each candidate comes out as a :class:`Candidate`: its
cell-level p-value (the rank: what it explains, Seber & Lee §4.3) and the p-value of its
test with the evidence counted per cycle (:mod:`setupfix.diagnose.inference`), the one
the selection accepts on.  Cross-validation over cycles: :func:`cv_sse`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import scipy.stats

from setupfix.diagnose.fit import Observations
from setupfix.diagnose.inference import MIN_CYCLES, cell_pvalue, cluster_test, cluster_wald, orth
from setupfix.diagnose.support import STATIC
from setupfix.diagnose.terms import EffectSpec

__all__ = ["TRIES", "Candidate", "dense_scores", "relation_scores", "cv_sse", "tested", "tested_sets", "prune_set"]

Array = npt.NDArray[np.float64]

_TINY = 1e-9

#: One-column candidates tested per cycle in a selection step, best-ranked first.
TRIES = 64


class Candidate(NamedTuple):
    """One candidate of a selection step: rank (cell-level p), per-cycle p, statistic, its terms, and where its
    columns are (index into the one-column candidates, −1 a relation, −2 − i the i-th process set)."""

    rank: float
    p: float
    stat: float
    specs: tuple[EffectSpec, ...]
    column: int


def dense_scores(Q: Array, r: Array, Z: Array) -> tuple[Array, Array]:
    """ΔRSS and residual column norm² of one-column candidates Z (N, m)."""
    qz = Q.T @ Z
    g = np.einsum("ij,ij->j", Z, Z) - np.einsum("ij,ij->j", qz, qz)
    t = Z.T @ r
    scale = np.einsum("ij,ij->j", Z, Z)
    ok = g > 1e-8 * np.maximum(scale, _TINY)
    gain = np.where(ok, t**2 / np.where(ok, g, 1.0), 0.0)
    return gain, np.where(ok, g, 0.0)


def relation_scores(
    Q: Array, r: Array, obs: Observations, applied: Array, pairs_ok: npt.NDArray[np.bool_]
) -> tuple[Array, Array]:
    """ΔRSS of every relation candidate (register i, dimension q), shape (n_registers, n_dimensions),
    and the part of it due to the slope (beyond the free constant on q alone).

    Two columns per candidate: a = u_i on the cells of q, b = 1 on the cells of q.
    Gram and cross products come from per-dimension sums (Q orthonormal, Qᵀr = 0).
    """
    n_r = applied.shape[1]
    n_d = pairs_ok.shape[1]
    gain = np.zeros((n_r, n_d))
    const = np.zeros(n_d)
    for q in range(n_d):
        if not pairs_ok[:, q].any():
            continue
        rows = np.flatnonzero(obs.dim == q)
        U = applied[obs.cycle[rows]]  # (n_q, n_r)
        Qq = Q[rows]  # (n_q, p)
        rq = r[rows]
        qa = Qq.T @ U  # (p, n_r)
        qb = Qq.sum(axis=0)  # (p,)
        aa = np.einsum("ij,ij->j", U, U) - np.einsum("ij,ij->j", qa, qa)
        ab = U.sum(axis=0) - qa.T @ qb
        bb = len(rows) - qb @ qb
        ta = U.T @ rq
        tb = rq.sum()
        G = np.empty((n_r, 2, 2))
        G[:, 0, 0], G[:, 0, 1], G[:, 1, 0], G[:, 1, 1] = aa, ab, ab, bb
        t = np.column_stack([ta, np.full(n_r, tb)])
        Gi = np.linalg.pinv(G, rcond=1e-10)
        gain[:, q] = np.where(pairs_ok[:, q], np.einsum("ri,rij,rj->r", t, Gi, t), 0.0)
        const[q] = tb**2 / bb if bb > _TINY else 0.0
    return gain, np.maximum(gain - const[None, :], 0.0)


def cv_sse(X: Array, z: Array, fold: npt.NDArray[np.intp], n_folds: int) -> float:
    """K-fold cross-validated squared prediction error (``fold`` of each cell: its cycle's rank in time mod K)."""
    sse = 0.0
    for f in range(n_folds):
        test = fold == f
        coef = np.linalg.lstsq(X[~test], z[~test], rcond=None)[0]
        e = z[test] - X[test] @ coef
        sse += float(e @ e)
    return sse


def tested(
    specs: list[EffectSpec],
    gain: Array,
    Q: Array,
    r: Array,
    Z: Array,
    obs: Observations,
    n_cycles: int,
    lof: tuple[float, int] | None,
    rss0: float,
    df0: int,
    limit: int = TRIES,
) -> list[Candidate]:
    """The ``limit`` best-ranked active one-column candidates (``gain`` ≥ 0): ranked by the cell-level p-value
    (static ones against the lack of fit when there is one), tested per cycle.

    Only the best-ranked ``limit`` are tested per cycle (the cost of the test is linear in the candidates and
    the cells); the selection's Bonferroni factor still counts every active candidate, so testing fewer only
    makes a report rarer.
    """
    idx = np.flatnonzero(gain >= 0)
    if idx.size == 0:
        return []
    g = gain[idx]
    df1 = max(df0 - 1, 1)
    f_cell = g / np.maximum((rss0 - g) / df1, 1e-300)
    p_cell = scipy.stats.f.sf(f_cell, 1, df1) if df0 - 1 > 0 else np.ones_like(g)
    static = np.array([specs[i].kind in STATIC for i in idx], dtype=bool)
    rank = p_cell.copy()
    if lof is not None:
        # dimensions keep offsets beyond the noise: a static effect must explain them, not the noise
        rank = np.where(static, _lof_p(g, lof), rank)
    keep = np.lexsort((-f_cell, rank))[:limit]
    out: list[Candidate] = []
    if n_cycles >= MIN_CYCLES:
        Zi = Z[:, idx[keep]]
        stat, p = cluster_test(Zi - Q @ (Q.T @ Zi), r, obs.cycle, n_cycles)
    for j, t in enumerate(keep):
        i = int(idx[t])
        if lof is not None and static[t]:
            out.append(Candidate(float(rank[t]), float(rank[t]), float(f_cell[t]), (specs[i],), i))
        elif n_cycles >= MIN_CYCLES:
            out.append(Candidate(float(p_cell[t]), float(p[j]), float(stat[j]), (specs[i],), i))
        else:
            out.append(Candidate(float(p_cell[t]), float(p_cell[t]), float(f_cell[t]), (specs[i],), i))
    return out


def _lof_p(gain: Array, lof: tuple[float, int]) -> Array:
    """Cell-level p-values of one-column gains against the lack of fit (:func:`cell_pvalue` vectorised)."""
    ss, df = lof
    df1 = df - 1
    if df1 <= 0:
        return np.ones_like(gain)
    out: Array = scipy.stats.f.sf(gain / np.maximum((ss - gain) / df1, 1e-300), 1, df1)
    return out


def tested_sets(
    sets: list[tuple[EffectSpec, ...]],
    blocks: list[Array],
    active: npt.NDArray[np.bool_],
    Q: Array,
    r: Array,
    obs: Observations,
    n_cycles: int,
    rss0: float,
    df0: int,
) -> list[Candidate]:
    """Every active per-register process set: ranked by its block's cell-level p-value, tested per cycle by the
    multi-column cluster-robust Wald test (:func:`~setupfix.diagnose.inference.cluster_wald`).  Sets are
    offered on series of at least ``MIN_CYCLES`` cycles only (a block needs cycles to be tested per cycle)."""
    out: list[Candidate] = []
    if n_cycles < MIN_CYCLES:
        return out
    for i, (members, Zb) in enumerate(zip(sets, blocks, strict=True)):
        if not active[i]:
            continue
        Zt = Zb - Q @ (Q.T @ Zb)
        f, p, q = cluster_wald(Zt, r, obs.cycle, n_cycles)
        if q < 2:  # one column left: the one-register candidates cover it
            continue
        t = orth(Zt).T @ r
        gain = float(t @ t)
        out.append(Candidate(cell_pvalue(gain, rss0, df0, q), p, f, members, -2 - i))
    return out


def prune_set(X: Array, block: Array, obs: Observations, n_cycles: int, alpha: float) -> list[int]:
    """Members of an accepted per-register set that earn their coefficient: the weakest member (largest
    per-cycle p-value given the model ``X`` and the other members kept) is dropped while that p-value is at
    least ``alpha``; the set keeps one member at least (the block as a whole passed its test).

    Returns
    -------
    list of int
        Column indices of ``block`` kept, in order.
    """
    kept = list(range(block.shape[1]))
    while len(kept) > 1:
        ps = []
        for j in kept:
            Q = orth(np.hstack([X, block[:, [i for i in kept if i != j]]]))
            r = obs.z - Q @ (Q.T @ obs.z)
            z = block[:, [j]] - Q @ (Q.T @ block[:, [j]])
            ps.append(float(cluster_test(z, r, obs.cycle, n_cycles)[1][0]))
        worst = int(np.argmax(ps))
        if ps[worst] < alpha:
            break
        kept.pop(worst)
    return kept
