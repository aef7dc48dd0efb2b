"""Trace the residual: candidate effects and forward selection with an honest criterion.

Each candidate is a term on covariates the series carries (the kinds of
:data:`setupfix.diagnose.terms.KINDS`).  Each step ranks the candidates by what they
explain (the cell-level nested F-test F = (ΔRSS / k) / (RSS₁ / (N − p − k)), Seber & Lee,
*Linear Regression Analysis*, §4.3; static kinds and relations against the lack of fit
when the dimensions keep offsets beyond the cycle-to-cycle noise) and accepts the first,
in that order, that

* passes its test with the evidence counted per cycle, not per cell
  (:mod:`setupfix.diagnose.inference`: cluster-robust test with the cycle as the cluster
  for every kind that changes between cycles, the lack of fit for static kinds, the
  dimension's own variation for a relation), Bonferroni-adjusted over the candidates of
  the step (p · m < ``alpha``; the union bound holds for every candidate tried), and
* lowers the K-fold cross-validated prediction error over cycles, for the kinds that
  change between cycles (folds deal the cycles in time order, so the parts' order does
  not matter; static kinds are the same on every cycle and their evidence is the
  dimensions' offsets, which held-out cycles cannot add to).

A candidate refused passes the turn to the next (the selection keeps trying); a step
ends with the first accepted or when none is left.  Series of fewer than four cycles:
cell-level F-test only, no CV (said in the notes).  Under the declared model with
Gaussian noise — independent or shared by the cells of a part — the chance of reporting
any effect is therefore at most ``alpha`` (``bench/diagnose_calibration.py``).  Scale and
position are offered only when the nominal sizes or positions are spread over their
range (:mod:`setupfix.diagnose.support`).

Candidates whose residualised columns are (nearly) zero cannot be identified from
the series (they are absorbed by the registers or their covariate never moved);
candidates whose residualised columns are nearly collinear with the chosen one
cannot be told apart from it.  Both are reported, never guessed.

The relation candidates (register i × dimension q) are scored from per-dimension
sums, without forming their N-row columns, so the cost stays linear in the cycles.
The register of a relation found is reported as a confidence set: every register
whose corrections the data cannot tell from the chosen one's (encompassing F-tests,
:func:`setupfix.diagnose.inference.relation_set`); registers that moved together are never told apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.optimize
import scipy.stats

from setupfix.diagnose.fit import Observations, effect_columns, observations
from setupfix.diagnose.inference import (MIN_CYCLES, cell_pvalue, cluster_test, dimension_pvalue, lack_of_fit,
                                         orth, relation_set)
from setupfix.diagnose.support import alike, register_notes, spread, support_notes
from setupfix.diagnose.terms import AXES, EffectSpec, Layout, Series

__all__ = ["Step", "Selection", "STATIC", "candidate_specs", "select_effects"]

Array = npt.NDArray[np.float64]

_TINY = 1e-9


@dataclass(frozen=True)
class Step:
    """One candidate tried by the forward selection: accepted, refused by cross-validation, or the best-ranked
    one its test refused in a step."""

    spec: EffectSpec
    f: float
    p: float
    p_adjusted: float
    tested: int
    cv_before: float
    cv_after: float
    accepted: bool
    alike: tuple[str, ...] = ()


@dataclass(frozen=True)
class Selection:
    """Result of the forward selection.

    Attributes
    ----------
    found : tuple of EffectSpec
        Accepted effects in order.
    steps : tuple of Step
        Every candidate tried, in order: accepted, refused by cross-validation, and per step the
        best-ranked one its test refused.
    unidentifiable : tuple of str
        Targets the series cannot identify.
    notes : tuple of str
    lack_of_fit : bool
        The dimensions keep constant offsets beyond the cycle-to-cycle noise after the
        effects found (lack-of-fit F-test at ``alpha``).
    """

    found: tuple[EffectSpec, ...]
    steps: tuple[Step, ...]
    unidentifiable: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())
    lack_of_fit: bool = False

    @property
    def unnamed(self) -> tuple[EffectSpec, ...]:
        """Relations found whose register the series cannot name (others are as likely: ``Step.alike``)."""
        return tuple(s.spec for s in self.steps if s.accepted and s.spec.kind == "relation" and s.alike)


def candidate_specs(layout: Layout, series: Series, *, taus: tuple[float, ...] = (0.1, 0.25, 0.5),
                    max_positions: int = 32, min_side: int = 2) -> list[EffectSpec]:
    """Every non-relation candidate the series' covariates allow.

    Parameters
    ----------
    taus : tuple of float
        Time constants of saturating drifts, as fractions of the series' time span.
    max_positions : int, default=32
        Level steps are tried at every cycle boundary with at least ``min_side`` cycles
        on each side, thinned to this many evenly spread positions on long series; the
        first cycle after a logged tool change is always a position.  Each position ×
        register is one candidate, so the selection's Bonferroni factor counts every
        position tried (a step found anywhere is held to the family-wise ``alpha``).
    min_side : int, default=2
        Cycles needed before and after a step (one cycle alone is an outlier, not a level).
    """
    out: list[EffectSpec] = []
    n = series.n_cycles
    span = float(np.ptp(series.time)) if n else 0.0
    if n >= 3 and span > 0:
        out.append(EffectSpec("drift", shape="linear"))
        out += [EffectSpec("drift", shape="saturating", tau=round(f * span, 3)) for f in taus]
    process = set(series.process_channels)
    for c, name in enumerate(series.channels):
        col = series.temperature[:, c]
        if n >= 3 and np.ptp(col) > 0 and name not in process:
            out.append(EffectSpec("thermal", channel=name, reference=float(np.round(np.mean(col), 2))))
    for k, j in enumerate(layout.tools):
        if n >= 3 and np.ptp(series.parts[:, k]) > 0:
            out.append(EffectSpec("wear", register=layout.register_ids[j]))
    if spread(layout.nominal):
        out.append(EffectSpec("scale"))
    for a, axis in enumerate(AXES):
        col = layout.coord[:, a]
        if np.isfinite(col).all() and spread(col):
            out.append(EffectSpec("position", axis=axis))
    for g in dict.fromkeys(g for g in layout.groups if g is not None):
        out.append(EffectSpec("group", group=g))
    targets: tuple[str | None, ...] = (None, *layout.register_ids)
    for k in _level_positions(series, max_positions, min_side):
        cyc = series.cycles[k] if series.cycles else f"cycle {k + 1}"
        out += [EffectSpec("level", register=r, at=float(series.time[k]), cycle=cyc) for r in targets]
    for c, name in enumerate(series.channels):
        col = series.temperature[:, c]
        if n >= 3 and np.ptp(col) > 0 and name in process:
            ref = float(f"{np.mean(col):.4g}")
            out += [EffectSpec("process", channel=name, register=r, reference=ref) for r in targets]
    return out


def _level_positions(series: Series, max_positions: int, min_side: int) -> list[int]:
    """Cycles a level step may start at: indices into the series (in any reading order) of the cycles, taken
    in time order, whose time is strictly after the previous cycle's, with ``min_side`` cycles on each side;
    the first cycle after a logged tool change is always one."""
    n = series.n_cycles
    order = np.argsort(series.time, kind="stable")
    t = series.time[order]
    ok = [j for j in range(min_side, n - min_side + 1) if t[j] > t[j - 1]]
    if len(ok) > max_positions:
        ok = [ok[int(i)] for i in np.unique(np.round(np.linspace(0, len(ok) - 1, max_positions)))]
    parts = series.parts[order]
    reset = (parts[1:] == 0) & (parts[:-1] > 0)  # a logged tool change restarted the count
    changed = {int(j) + 1 for j in np.flatnonzero(reset.any(axis=1))} if n > 1 else set()
    return [int(order[j]) for j in sorted(set(ok) | {j for j in changed if t[j] > t[j - 1]})]


def _dense_scores(Q: Array, r: Array, Z: Array) -> tuple[Array, Array]:
    """ΔRSS and residual column norm² of one-column candidates Z (N, m)."""
    qz = Q.T @ Z
    g = np.einsum("ij,ij->j", Z, Z) - np.einsum("ij,ij->j", qz, qz)
    t = Z.T @ r
    scale = np.einsum("ij,ij->j", Z, Z)
    ok = g > 1e-8 * np.maximum(scale, _TINY)
    gain = np.where(ok, t ** 2 / np.where(ok, g, 1.0), 0.0)
    return gain, np.where(ok, g, 0.0)


def _relation_scores(Q: Array, r: Array, obs: Observations, applied: Array,
                     pairs_ok: npt.NDArray[np.bool_]) -> tuple[Array, Array]:
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
        const[q] = tb ** 2 / bb if bb > _TINY else 0.0
    return gain, np.maximum(gain - const[None, :], 0.0)


def _cv_sse(X: Array, z: Array, fold: npt.NDArray[np.intp], n_folds: int) -> float:
    """K-fold cross-validated squared prediction error (``fold`` of each cell: its cycle's rank in time mod K)."""
    sse = 0.0
    for f in range(n_folds):
        test = fold == f
        coef = np.linalg.lstsq(X[~test], z[~test], rcond=None)[0]
        e = z[test] - X[test] @ coef
        sse += float(e @ e)
    return sse


def select_effects(layout: Layout, series: Series, *, alpha: float = 0.01, max_effects: int = 4,
                   n_folds: int = 5, relations: bool = True, obs: Observations | None = None,
                   declared: tuple[EffectSpec, ...] = ()) -> Selection:
    """Forward selection of the effects the declared model lacks.

    Parameters
    ----------
    layout : Layout
    series : Series
    alpha : float, default=0.01
        Family-wise level of each step (Bonferroni over the candidates tested).
    max_effects : int, default=4
    n_folds : int, default=5
        Folds of the cross-validation over cycles (cycles dealt to folds in time order).
    relations : bool, default=True
        Test the relation candidates (register × dimension).
    declared : tuple of EffectSpec
        Effects the model already has (its ``[effects]``): part of the base, never candidates.

    Returns
    -------
    Selection
    """
    obs = observations(layout, series) if obs is None else obs
    specs = [s for s in candidate_specs(layout, series) if s not in declared]
    dense = [effect_columns(s, layout, series, obs)[:, 0] for s in specs]
    Z = np.column_stack(dense) if dense else np.zeros((obs.n, 0))
    C = layout.composite
    n_r, n_d = C.shape
    n_cyc = series.n_cycles
    # relation pairs: the register's applied change must take ≥ 2 values on the dimension's cells
    pairs_ok = np.zeros((n_r, n_d), dtype=bool)
    if relations and n_cyc >= 3:
        for q in range(n_d):
            cyc = np.unique(obs.cycle[obs.dim == q])
            if cyc.size >= 3:
                pairs_ok[:, q] = np.ptp(series.applied[cyc], axis=0) > _TINY
    notes: list[str] = support_notes(layout)
    X = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in declared])
    found: list[EffectSpec] = []
    steps: list[Step] = []
    unident: list[str] = []
    folds = min(n_folds, n_cyc)
    by_cycle = n_cyc >= MIN_CYCLES
    if not by_cycle:
        notes.append(f"{n_cyc} cycle(s): effects are tested by the F-test only, counting cells (no cross-validation "
                     "over cycles, no test per part); only static effects (scale, position, group) can be found")
    # folds deal the cycles in time order: the same folds whatever order the parts come in
    fold_of = (np.argsort(np.argsort(series.time, kind="stable"), kind="stable") % max(folds, 1))[obs.cycle]
    active_dense = np.ones(len(specs), dtype=bool)
    active_rel = pairs_ok.copy()
    for s in declared:
        if s.kind == "relation":
            active_rel[layout.register_ids.index(str(s.register)), layout.dimension_ids.index(str(s.dimension))] = False
    first = True
    while len(found) < max_effects:
        Q = orth(X)
        r = obs.z - Q @ (Q.T @ obs.z)
        rss0 = float(r @ r)
        df0 = obs.n - Q.shape[1]
        gain_d, g = _dense_scores(Q, r, Z) if Z.shape[1] else (np.zeros(0), np.zeros(0))
        if first:
            unident += [s.target for s, gi, a in zip(specs, g, active_dense, strict=True) if a and gi == 0.0]
            first = False
        gain_d = np.where(active_dense & (g > 0), gain_d, -1.0)
        gain_r, slope_r = (_relation_scores(Q, r, obs, series.applied, active_rel) if active_rel.any()
                           else (None, None))
        m = int(np.sum(gain_d >= 0)) + (int(active_rel.sum()) if gain_r is not None else 0)
        if m == 0 or df0 <= 2:
            break
        n_static = obs.base.shape[1] + sum(s.kind in STATIC for s in (*declared, *found))
        lof = lack_of_fit(obs.dim, r, obs.n, n_static, alpha) if n_cyc >= 2 else None
        cands = _tested(specs, gain_d, Q, r, Z, obs, n_cyc, lof, rss0, df0)
        if gain_r is not None and slope_r is not None:
            # the dimension most off (slope and constant), then the register whose changes it answers (slope)
            q_r = int(np.unravel_index(int(np.argmax(np.where(active_rel, gain_r, -1.0))), gain_r.shape)[1])
            i_r = int(np.argmax(np.where(active_rel[:, q_r], slope_r[:, q_r], -1.0)))
            if active_rel[i_r, q_r]:
                spec = EffectSpec("relation", register=layout.register_ids[i_r], dimension=layout.dimension_ids[q_r])
                g_r = float(gain_r[i_r, q_r])
                # two kinds of evidence, Bonferroni over both: the slope (the dimension answers the register's
                # changes) against that dimension's own variation over cycles, and, when the dimensions keep
                # offsets, its free constant (δ · s_i on one dimension) against the lack of fit
                r_q = r[obs.dim == q_r]
                slope = float(slope_r[i_r, q_r])
                if by_cycle:
                    p_r = dimension_pvalue(slope, r_q - r_q.mean(), 1)
                    if lof is not None:
                        p_r = min(1.0, 2.0 * min(p_r, cell_pvalue(g_r - slope, lof[0], lof[1], 1)))
                    rank_r = p_r if lof is not None else cell_pvalue(g_r, rss0, df0, 2)
                else:
                    p_r = rank_r = cell_pvalue(g_r, rss0, df0, 2)
                f_r = (g_r / 2) / max((rss0 - g_r) / max(df0 - 2, 1), 1e-300)
                cands.append((rank_r, p_r, f_r, spec, -1))
        # ranked by what each explains (cell-level p-value), accepted on the per-cycle test at α / m
        # (Bonferroni holds for every candidate tried) and cross-validation
        cands.sort(key=lambda c: (c[0], -c[2]))
        cv0 = _cv_sse(X, obs.z, fold_of, folds) if by_cycle else float("nan")
        accepted = refused = False
        for _, p, f_stat, spec, di in cands:
            # keep trying: a candidate refused passes the turn to the next in rank
            p_adj = min(1.0, p * m)
            if p_adj >= alpha:
                if not refused:  # the best-ranked candidate the test refuses is reported
                    steps.append(Step(spec, float(f_stat), float(p), float(p_adj), m, float("nan"), float("nan"),
                                      False))
                refused = True
                continue
            if spec.kind == "drift" and spec.shape == "saturating":
                spec = _refine_tau(spec, layout, series, obs, Q, r)
            if spec.kind == "level":  # the step's cycle between the positions tried
                spec, _ = _refine_level(spec, layout, series, obs, Q, r,
                                        float(_dense_scores(Q, r, effect_columns(spec, layout, series, obs))[0][0]))
            cols = Z[:, [di]] if di >= 0 and spec == specs[di] else effect_columns(spec, layout, series, obs)
            X1 = np.hstack([X, cols])
            cv1 = float("nan")
            # a static term is the same on every cycle: its evidence is the dimensions' offsets (the test),
            # which held-out cycles cannot add to; time-dependent terms must also predict held-out cycles
            ok = True
            if by_cycle and spec.kind not in STATIC:
                cv1 = _cv_sse(X1, obs.z, fold_of, folds)
                ok = cv1 < cv0
            if not ok:
                steps.append(Step(spec, float(f_stat), float(p), float(p_adj), m, cv0, cv1, False))
                continue
            if di >= 0:
                same = alike(Q, cols[:, 0], Z, specs, active_dense, di)
            else:
                same = relation_set(Q, r, obs, series.applied, layout, spec, alpha)
            steps.append(Step(spec, float(f_stat), float(p), float(p_adj), m, cv0, cv1, True, same))
            found.append(spec)
            X = X1
            if di >= 0:
                active_dense[di] = False
                if spec.kind == "drift":  # one drift shape at most
                    active_dense &= np.array([s.kind != "drift" for s in specs])
            else:
                active_rel[layout.register_ids.index(str(spec.register)),
                           layout.dimension_ids.index(str(spec.dimension))] = False
            accepted = True
            break
        if not accepted:
            break
    lack = False
    if n_cyc >= 2:
        Q = orth(X)
        r = obs.z - Q @ (Q.T @ obs.z)
        n_static = obs.base.shape[1] + sum(s.kind in STATIC for s in (*declared, *found))
        lack = lack_of_fit(obs.dim, r, obs.n, n_static, alpha) is not None
        if lack:
            notes.append("the dimensions keep constant offsets beyond the noise that no candidate explains "
                         "(lack of fit): a register or relation the model lacks on single dimensions?")
    notes += register_notes(layout, series, obs)
    return Selection(tuple(found), tuple(steps), tuple(dict.fromkeys(unident)), tuple(notes), lack)


#: Kinds whose field is the same on every cycle.
STATIC = ("scale", "position", "group")


def _tested(specs: list[EffectSpec], gain: Array, Q: Array, r: Array, Z: Array, obs: Observations, n_cycles: int,
            lof: tuple[float, int] | None, rss0: float, df0: int) -> list[tuple[float, float, float, EffectSpec, int]]:
    """(rank, p, statistic, spec, column) of every active one-column candidate (``gain`` ≥ 0): ranked by the
    cell-level p-value, tested per cycle (:mod:`setupfix.diagnose.inference`); static ones against the lack of
    fit when there is one."""
    idx = np.flatnonzero(gain >= 0)
    out: list[tuple[float, float, float, EffectSpec, int]] = []
    if idx.size == 0:
        return out
    if n_cycles >= MIN_CYCLES:
        Zi = Z[:, idx]
        stat, p = cluster_test(Zi - Q @ (Q.T @ Zi), r, obs.cycle, n_cycles)
    for j, i in enumerate(idx):
        f_cell = float(gain[i] / max((rss0 - gain[i]) / max(df0 - 1, 1), 1e-300))
        p_cell = cell_pvalue(float(gain[i]), rss0, df0, 1)
        if lof is not None and specs[i].kind in STATIC:
            # dimensions keep offsets beyond the noise: a static effect must explain them, not the noise
            p_lof = cell_pvalue(float(gain[i]), lof[0], lof[1], 1)
            out.append((p_lof, p_lof, f_cell, specs[i], int(i)))
        elif n_cycles >= MIN_CYCLES:
            out.append((p_cell, float(p[j]), float(stat[j]), specs[i], int(i)))
        else:
            out.append((p_cell, p_cell, f_cell, specs[i], int(i)))
    return out


def _refine_level(spec: EffectSpec, layout: Layout, series: Series, obs: Observations, Q: Array, r: Array,
                  gain: float, min_side: int = 2) -> tuple[EffectSpec, float]:
    """A level step moved to the cycle boundary, between its neighbouring positions tried, that explains most.

    On long series :func:`candidate_specs` tries a thinned set of positions; the
    accepted step (tested at its own position, counted in the Bonferroni factor) is
    placed at the best boundary up to the next positions tried on either side (cycles
    taken in time order, whatever the reading order of the series).
    """
    n = series.n_cycles
    order = np.argsort(series.time, kind="stable")
    t = series.time[order]
    k0 = int(np.searchsorted(t, spec.at, side="left"))
    tried = sorted({float(c.at) for c in candidate_specs(layout, series) if c.kind == "level"})
    i = tried.index(spec.at) if spec.at in tried else -1
    lo = int(np.searchsorted(t, tried[i - 1], side="left")) + 1 if i > 0 else min_side
    hi = int(np.searchsorted(t, tried[i + 1], side="left")) - 1 if 0 <= i < len(tried) - 1 else n - min_side
    ks = [k for k in range(max(lo, min_side), min(hi, n - min_side) + 1) if k != k0 and t[k] > t[k - 1]]
    if not ks:
        return spec, gain
    alts = [EffectSpec("level", register=spec.register, at=float(t[k]),
                       cycle=series.cycles[int(order[k])] if series.cycles else f"cycle {int(order[k]) + 1}")
            for k in ks]
    g = _dense_scores(Q, r, np.column_stack([effect_columns(a, layout, series, obs)[:, 0] for a in alts]))[0]
    best = int(np.argmax(g))
    return (alts[best], float(g[best])) if g[best] > gain else (spec, gain)


def _refine_tau(spec: EffectSpec, layout: Layout, series: Series, obs: Observations, Q: Array,
                r: Array) -> EffectSpec:
    """Time constant of a saturating drift refined by a bounded 1-D search on the residual."""
    span = float(np.ptp(series.time))

    def loss(log_tau: float) -> float:
        s = EffectSpec("drift", shape="saturating", tau=float(np.exp(log_tau)))
        return -float(_dense_scores(Q, r, effect_columns(s, layout, series, obs))[0][0])

    res = scipy.optimize.minimize_scalar(loss, bounds=(np.log(0.02 * span), np.log(2.0 * span)), method="bounded",
                                         options={"xatol": 1e-3})
    tau = float(np.exp(res.x)) if res.fun < loss(np.log(spec.tau)) else spec.tau
    return EffectSpec("drift", shape="saturating", tau=float(f"{tau:.4g}"))
