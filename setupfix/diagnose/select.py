"""Trace the residual: candidate effects and forward selection with an honest criterion.

Each candidate is a term on covariates the series carries (the kinds of
:data:`setupfix.diagnose.terms.KINDS`).  Forward selection adds, one at a time, the
candidate with the smallest p-value of the nested F-test

    F = (ΔRSS / k) / (RSS₁ / (N − p − k))

(k columns added, Seber & Lee, *Linear Regression Analysis*, §4.3; a static effect —
scale, position, group — is tested against the lack of fit, the per-dimension mean
residuals, when those exceed the cycle-to-cycle noise: with cycles as replicates a
static pattern must explain the dimensions' offsets, not the noise) as long as the
Bonferroni-adjusted p-value (p · number of candidates tested in that step) stays
below ``alpha`` *and* the term lowers the K-fold cross-validated prediction error
over cycles (folds interleave the cycles; no CV for series of fewer than four
cycles, said in the notes).  Under the declared model with Gaussian noise the
chance of reporting any effect is therefore at most ``alpha``.

Candidates whose residualised columns are (nearly) zero cannot be identified from
the series (they are absorbed by the registers or their covariate never moved);
candidates whose residualised columns are nearly collinear with the chosen one
cannot be told apart from it.  Both are reported, never guessed.

The relation candidates (register i × dimension q) are scored from per-dimension
sums, without forming their N-row columns, so the cost stays linear in the cycles.
The register of a relation found is reported as a confidence set: every register
whose corrections the data cannot tell from the chosen one's (encompassing F-tests,
:func:`_relation_set`); registers that moved together are never told apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.optimize
import scipy.stats

from setupfix.diagnose.fit import Observations, effect_columns, observations
from setupfix.diagnose.terms import AXES, EffectSpec, Layout, Series
from setupfix.relation import null_space_directions

__all__ = ["Step", "Selection", "candidate_specs", "select_effects"]

Array = npt.NDArray[np.float64]

_TINY = 1e-9


@dataclass(frozen=True)
class Step:
    """One accepted (or the first rejected) candidate of the forward selection."""

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
        Accepted steps, then the rejected best candidate (if any).
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
    if np.ptp(layout.nominal) > 0:
        out.append(EffectSpec("scale"))
    for a, axis in enumerate(AXES):
        col = layout.coord[:, a]
        if np.isfinite(col).all() and np.ptp(col) > 0:
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
    """Cycle indices a level step may start at (time strictly after the previous cycle's)."""
    n = series.n_cycles
    t = series.time
    ok = [k for k in range(min_side, n - min_side + 1) if t[k] > t[k - 1]]
    if len(ok) > max_positions:
        ok = [ok[int(i)] for i in np.unique(np.round(np.linspace(0, len(ok) - 1, max_positions)))]
    reset = (series.parts[1:] == 0) & (series.parts[:-1] > 0)  # a logged tool change restarted the count
    changed = {int(k) + 1 for k in np.flatnonzero(reset.any(axis=1))} if n > 1 else set()
    return sorted(set(ok) | {k for k in changed if t[k] > t[k - 1]})


def _orth(X: Array) -> Array:
    if X.shape[1] == 0:
        return X
    u, s, _ = np.linalg.svd(X, full_matrices=False)
    keep = s > _TINY * max(1.0, float(s.max(initial=0.0)))
    out: Array = u[:, keep]
    return out


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


def _cv_sse(X: Array, z: Array, cycle: npt.NDArray[np.intp], n_folds: int) -> float:
    """K-fold (interleaved cycles) cross-validated squared prediction error."""
    fold = cycle % n_folds
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
        Folds of the cross-validation over cycles.
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
    # relation pairs: the register's applied change must take ≥ 2 values on the dimension's cells
    pairs_ok = np.zeros((n_r, n_d), dtype=bool)
    if relations and series.n_cycles >= 3:
        for q in range(n_d):
            cyc = np.unique(obs.cycle[obs.dim == q])
            if cyc.size >= 3:
                pairs_ok[:, q] = np.ptp(series.applied[cyc], axis=0) > _TINY
    notes: list[str] = []
    X = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in declared])
    found: list[EffectSpec] = []
    blocks: list[Array] = []
    steps: list[Step] = []
    unident: list[str] = []
    folds = min(n_folds, series.n_cycles)
    use_cv = series.n_cycles >= 4
    if not use_cv:
        notes.append(f"{series.n_cycles} cycle(s): effects are tested by the F-test only (no cross-validation "
                     "over cycles); only static effects (scale, position, group) can be found")
    active_dense = np.ones(len(specs), dtype=bool)
    active_rel = pairs_ok.copy()
    for s in declared:
        if s.kind == "relation":
            active_rel[layout.register_ids.index(str(s.register)), layout.dimension_ids.index(str(s.dimension))] = False
    first = True
    while len(found) < max_effects:
        Q = _orth(X)
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
        n_static = obs.base.shape[1] + sum(s.kind in _STATIC for s in (*declared, *found))
        lof = _lack_of_fit(obs, r, n_static, alpha) if series.n_cycles >= 2 else None
        cands: list[tuple[float, int, EffectSpec, int, float]] = []  # (p, k, spec, dense index or -1, ΔRSS)
        for i in np.flatnonzero(gain_d >= 0):
            if lof is not None and specs[i].kind in _STATIC:
                # dimensions keep offsets beyond the noise: a static effect must explain them, not the noise
                p_i = _pvalue(gain_d[i], lof[0], lof[1], 1)
            else:
                p_i = _pvalue(gain_d[i], rss0, df0, 1)
            cands.append((p_i, 1, specs[i], int(i), float(gain_d[i])))
        if gain_r is not None and slope_r is not None:
            # the dimension most off (slope and constant), then the register whose changes it answers (slope)
            q_r = int(np.unravel_index(int(np.argmax(np.where(active_rel, gain_r, -1.0))), gain_r.shape)[1])
            i_r = int(np.argmax(np.where(active_rel[:, q_r], slope_r[:, q_r], -1.0)))
            if active_rel[i_r, q_r]:
                spec = EffectSpec("relation", register=layout.register_ids[i_r], dimension=layout.dimension_ids[q_r])
                g_r = float(gain_r[i_r, q_r])
                # its free constant takes one dimension's offset: against the lack of fit when there is one
                p_r = _pvalue(g_r, lof[0], lof[1], 2) if lof is not None else _pvalue(g_r, rss0, df0, 2)
                cands.append((p_r, 2, spec, -1, g_r))
        # ties (p-values that underflow to 0 for strong effects) go to the larger ΔRSS
        p, k, spec, di, gain = min(cands, key=lambda c: (c[0], -c[4]))
        p_adj = min(1.0, p * m)
        f_stat = (gain / k) / max((rss0 - gain) / max(df0 - k, 1), 1e-300)
        if spec.kind == "drift" and spec.shape == "saturating":
            spec = _refine_tau(spec, layout, series, obs, Q, r)
            gain = _dense_scores(Q, r, effect_columns(spec, layout, series, obs))[0][0]
            f_stat = (gain / k) / max((rss0 - gain) / max(df0 - k, 1), 1e-300)
        if spec.kind == "level" and p * m < alpha:  # the step's cycle between the positions tried
            spec, gain = _refine_level(spec, layout, series, obs, Q, r, gain)
            f_stat = (gain / k) / max((rss0 - gain) / max(df0 - k, 1), 1e-300)
        cols = Z[:, [di]] if di >= 0 and spec == specs[di] else effect_columns(spec, layout, series, obs)
        X1 = np.hstack([X, cols])
        cv0 = cv1 = float("nan")
        ok = p_adj < alpha
        if ok and use_cv:
            cv0 = _cv_sse(X, obs.z, obs.cycle, folds)
            cv1 = _cv_sse(X1, obs.z, obs.cycle, folds)
            ok = cv1 < cv0
        if not ok:
            alike: tuple[str, ...] = ()
        elif di >= 0:
            alike = _alike(Q, cols[:, 0], Z, specs, active_dense, di)
        else:
            alike = _relation_set(Q, r, obs, series.applied, layout, spec, alpha)
        steps.append(Step(spec, float(f_stat), float(p), float(p_adj), m, cv0, cv1, ok, alike))
        if not ok:
            break
        found.append(spec)
        blocks.append(cols)
        X = X1
        if di >= 0:
            active_dense[di] = False
            if spec.kind == "drift":  # one drift shape at most
                active_dense &= np.array([s.kind != "drift" for s in specs])
        else:
            active_rel[layout.register_ids.index(str(spec.register)),
                       layout.dimension_ids.index(str(spec.dimension))] = False
    lack = False
    if series.n_cycles >= 2:
        Q = _orth(X)
        r = obs.z - Q @ (Q.T @ obs.z)
        n_static = obs.base.shape[1] + sum(s.kind in _STATIC for s in (*declared, *found))
        lack = _lack_of_fit(obs, r, n_static, alpha) is not None
        if lack:
            notes.append("the dimensions keep constant offsets beyond the noise that no candidate explains "
                         "(lack of fit): a register or relation the model lacks on single dimensions?")
    notes += _register_notes(layout, series, obs)
    return Selection(tuple(found), tuple(steps), tuple(dict.fromkeys(unident)), tuple(notes), lack)


_STATIC = ("scale", "position", "group")


def _lack_of_fit(obs: Observations, r: Array, n_static: int, alpha: float) -> tuple[float, int] | None:
    """(SS, df) of the per-dimension mean residuals when they exceed the cycle-to-cycle noise, else None.

    The classic lack-of-fit test with the cycles as replicates: SS_lof = Σ_q n_q r̄_q²
    on (dimensions − static parameters) df against the pure error Σ (r − r̄_q)².
    """
    n_q = np.bincount(obs.dim)
    seen = n_q > 0
    mean_q = np.bincount(obs.dim, weights=r)[seen] / n_q[seen]
    ss_lof = float(np.sum(n_q[seen] * mean_q ** 2))
    ss_pure = float(r @ r) - ss_lof
    df_lof = int(seen.sum()) - n_static
    df_pure = obs.n - int(seen.sum())
    if df_lof <= 1 or df_pure <= 1 or ss_pure <= 0:
        return None
    p = float(scipy.stats.f.sf((ss_lof / df_lof) / (ss_pure / df_pure), df_lof, df_pure))
    return (ss_lof, df_lof) if p < alpha else None


def _pvalue(gain: float, rss0: float, df0: int, k: int) -> float:
    df1 = df0 - k
    if df1 <= 0:
        return 1.0
    rss1 = max(rss0 - gain, 1e-300)
    f = (gain / k) / (rss1 / df1)
    return float(scipy.stats.f.sf(f, k, df1))


def _alike(Q: Array, col: Array, Z: Array, specs: list[EffectSpec], active: npt.NDArray[np.bool_],
           chosen: int, threshold: float = 0.98) -> tuple[str, ...]:
    """Candidates whose residualised columns are nearly collinear with the chosen one."""
    if Z.shape[1] == 0:
        return ()
    c = col - Q @ (Q.T @ col)
    P = Z - Q @ (Q.T @ Z)
    num = np.abs(P.T @ c)
    den = np.linalg.norm(P, axis=0) * np.linalg.norm(c)
    corr = np.where(den > _TINY, num / np.where(den > _TINY, den, 1.0), 0.0)
    return tuple(f"{specs[i].kind}: {specs[i].target}" for i in np.flatnonzero((corr > threshold) & active)
                 if i != chosen)


def _relation_set(Q: Array, r: Array, obs: Observations, applied: Array, layout: Layout, spec: EffectSpec,
                  alpha: float) -> tuple[str, ...]:
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
        B = _orth(P[:, cols])
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


def _refine_level(spec: EffectSpec, layout: Layout, series: Series, obs: Observations, Q: Array, r: Array,
                  gain: float, min_side: int = 2) -> tuple[EffectSpec, float]:
    """A level step moved to the cycle boundary, between its neighbouring positions tried, that explains most.

    On long series :func:`candidate_specs` tries a thinned set of positions; the
    accepted step (tested at its own position, counted in the Bonferroni factor) is
    placed at the best boundary up to the next positions tried on either side.
    """
    n = series.n_cycles
    t = series.time
    k0 = int(np.searchsorted(t, spec.at, side="left"))
    tried = sorted({float(c.at) for c in candidate_specs(layout, series) if c.kind == "level"})
    i = tried.index(spec.at) if spec.at in tried else -1
    lo = int(np.searchsorted(t, tried[i - 1], side="left")) + 1 if i > 0 else min_side
    hi = int(np.searchsorted(t, tried[i + 1], side="left")) - 1 if 0 <= i < len(tried) - 1 else n - min_side
    ks = [k for k in range(max(lo, min_side), min(hi, n - min_side) + 1) if k != k0 and t[k] > t[k - 1]]
    if not ks:
        return spec, gain
    alts = [EffectSpec("level", register=spec.register, at=float(t[k]),
                       cycle=series.cycles[k] if series.cycles else f"cycle {k + 1}") for k in ks]
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


def _register_notes(layout: Layout, series: Series, obs: Observations) -> list[str]:
    """Diagnosability of the registers from the applied corrections."""
    notes: list[str] = []
    u = series.applied - series.applied.mean(axis=0) if series.n_cycles else series.applied
    moved = np.ptp(series.applied, axis=0) > _TINY if series.n_cycles else np.zeros(layout.n_registers, bool)
    ids = layout.register_ids
    if series.n_cycles >= 3:
        still = [ids[i] for i in np.flatnonzero(~moved)]
        if still:
            notes.append("never corrected during the series, so how dimensions answer them cannot be checked: "
                         + ", ".join(still))
        idx = np.flatnonzero(moved)
        for a_pos, a in enumerate(idx):
            for b in idx[a_pos + 1:]:
                na, nb = np.linalg.norm(u[:, a]), np.linalg.norm(u[:, b])
                if abs(u[:, a] @ u[:, b]) > (1 - 1e-6) * na * nb:
                    notes.append(f"{ids[a]} and {ids[b]} always moved together: a wrong relation of one "
                                 "cannot be told from the other")
    for row in null_space_directions(layout.composite):
        terms = " ".join(f"{'+' if v > 0 else '-'}{'' if abs(v) == 1 else f'{abs(v):g}·'}{ids[i]}"
                         for i, v in enumerate(row) if v != 0)
        notes.append(f"the setup state is known only up to {terms.lstrip('+')} (moves no dimension)")
    return notes
