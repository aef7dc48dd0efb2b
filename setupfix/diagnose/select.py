"""Trace the residual: candidate effects and forward selection with an honest criterion.

Each candidate is a term on covariates the series carries (the kinds of
:data:`setupfix.diagnose.terms.KINDS`; :mod:`setupfix.diagnose.candidates`), or a block of
terms: a process channel on every tool with a coefficient each (a per-register set,
tested as one candidate by the multi-column cluster-robust Wald test and reported as one
``process`` effect per register).  Each step ranks the candidates by what they
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
ends with the first accepted or when none is left (of the one-column candidates the 64
best-ranked are tested per cycle, :data:`setupfix.diagnose.scores.TRIES`; the Bonferroni
factor counts them all).  An accepted per-register set keeps the registers that earn their
coefficient (:func:`setupfix.diagnose.scores.prune_set`), again once every effect is in.
Series of fewer than four cycles:
cell-level F-test only, no CV (said in the notes).  Under the declared model with
Gaussian noise — independent or shared by the cells of a part — the chance of reporting
any effect is therefore at most ``alpha`` (``bench/diagnose_calibration.py``).  Scale and
position are offered only when the nominal sizes or positions are spread over their
range (:mod:`setupfix.diagnose.support`).

Candidates whose residualised columns are (nearly) zero cannot be identified from
the series (they are absorbed by the registers or their covariate never moved);
candidates whose residualised columns are nearly collinear with the chosen one
cannot be told apart from it.  Both are reported, never guessed; so is a per-register set that
ranks first but leaves its per-part test no degrees of freedom (too few parts carry the channel
for a coefficient per register), which is not claimed.

The relation candidates (register i × dimension q) are scored from per-dimension
sums, without forming their N-row columns, so the cost stays linear in the cycles.
The register of a relation found is reported as a confidence set: every register
whose corrections the data cannot tell from the chosen one's (encompassing F-tests,
:func:`setupfix.diagnose.inference.relation_set`); registers that moved together are never told apart.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.candidates import STATIC, candidate_specs, process_sets, refine_level, refine_tau
from setupfix.diagnose.fit import Observations, dense_columns, effect_columns, observations
from setupfix.diagnose.inference import MIN_CYCLES, cell_pvalue, dimension_pvalue, lack_of_fit, orth, relation_set
from setupfix.diagnose.scores import Candidate, cv_sse, dense_scores, prune_set, relation_scores, tested, tested_sets
from setupfix.diagnose.support import alike, alike_sets, register_notes, spread, support_notes
from setupfix.diagnose.terms import EffectSpec, Layout, Series

__all__ = ["Step", "Selection", "STATIC", "candidate_specs", "select_effects", "spread"]

Array = npt.NDArray[np.float64]

_TINY = 1e-9


@dataclass(frozen=True)
class Step:
    """One candidate tried by the forward selection: accepted, refused by cross-validation, or the best-ranked
    one its test refused in a step.  A per-register set has its terms in ``members`` (``spec`` the first)."""

    spec: EffectSpec
    f: float
    p: float
    p_adjusted: float
    tested: int
    cv_before: float
    cv_after: float
    accepted: bool
    alike: tuple[str, ...] = ()
    members: tuple[EffectSpec, ...] = ()

    @property
    def terms(self) -> tuple[EffectSpec, ...]:
        """The effect terms of the candidate (one, or one per register of a set)."""
        return self.members or (self.spec,)

    @property
    def target(self) -> str:
        """What the candidate concerns (a set: its registers, a coefficient each)."""
        if len(self.terms) == 1:
            return self.spec.target
        regs = ", ".join(str(t.register) for t in self.terms)
        return f"{regs} ~ {self.spec.channel} (a coefficient each)"


@dataclass(frozen=True)
class Selection:
    """Result of the forward selection.

    Attributes
    ----------
    found : tuple of EffectSpec
        Accepted effects in order (a per-register set: one per register, in a row).
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

    def alike_of_found(self) -> tuple[tuple[str, ...], ...]:
        """``Step.alike`` of each effect in ``found`` (the members of a set share their step's)."""
        return tuple(s.alike for s in self.steps if s.accepted for _ in s.terms)


def select_effects(
    layout: Layout,
    series: Series,
    *,
    alpha: float = 0.01,
    max_effects: int = 4,
    n_folds: int = 5,
    relations: bool = True,
    obs: Observations | None = None,
    declared: tuple[EffectSpec, ...] = (),
) -> Selection:
    """Forward selection of the effects the declared model lacks.

    Parameters
    ----------
    layout : Layout
    series : Series
    alpha : float, default=0.01
        Family-wise level of each step (Bonferroni over the candidates tested).
    max_effects : int, default=4
        Candidates accepted at most (a per-register set counts once).
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
    Z = dense_columns(specs, layout, series, obs)
    sets = [m for m in process_sets(layout, series) if not set(m) & set(declared)]
    blocks = [dense_columns(list(m), layout, series, obs) for m in sets]
    active_set = np.ones(len(sets), dtype=bool)
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
        notes.append(
            f"{n_cyc} cycle(s): effects are tested by the F-test only, counting cells (no cross-validation "
            "over cycles, no test per part); only static effects (scale, position, group) can be found"
        )
    # folds deal the cycles in time order: the same folds whatever order the parts come in
    fold_of = (np.argsort(np.argsort(series.time, kind="stable"), kind="stable") % max(folds, 1))[obs.cycle]
    active_dense = np.ones(len(specs), dtype=bool)
    active_rel = pairs_ok.copy()
    for s in declared:
        if s.kind == "relation":
            active_rel[layout.register_ids.index(str(s.register)), layout.dimension_ids.index(str(s.dimension))] = False
    first = True
    n_accepted = 0
    while n_accepted < max_effects:
        Q = orth(X)
        r = obs.z - Q @ (Q.T @ obs.z)
        rss0 = float(r @ r)
        df0 = obs.n - Q.shape[1]
        gain_d, g = dense_scores(Q, r, Z) if Z.shape[1] else (np.zeros(0), np.zeros(0))
        if first:
            unident += [s.target for s, gi, a in zip(specs, g, active_dense, strict=True) if a and gi == 0.0]
            first = False
        gain_d = np.where(active_dense & (g > 0), gain_d, -1.0)
        gain_r, slope_r = relation_scores(Q, r, obs, series.applied, active_rel) if active_rel.any() else (None, None)
        set_cands = tested_sets(sets, blocks, active_set, Q, r, obs, n_cyc, rss0, df0)
        m = int(np.sum(gain_d >= 0)) + len(set_cands) + (int(active_rel.sum()) if gain_r is not None else 0)
        if m == 0 or df0 <= 2:
            break
        n_static = obs.base.shape[1] + sum(s.kind in STATIC for s in (*declared, *found))
        lof = lack_of_fit(obs.dim, r, obs.n, n_static, alpha) if n_cyc >= 2 else None
        cands = tested(specs, gain_d, Q, r, Z, obs, n_cyc, lof, rss0, df0) + set_cands
        if gain_r is not None and slope_r is not None:
            rel = relation_candidate(layout, obs, gain_r, slope_r, active_rel, r, rss0, df0, by_cycle, lof)
            if rel is not None:
                cands.append(rel)
        # ranked by what each explains (cell-level p-value), accepted on the per-cycle test at α / m
        # (Bonferroni holds for every candidate tried) and cross-validation
        cands.sort(key=lambda c: (c.rank, -c.stat))
        cv0 = cv_sse(X, obs.z, fold_of, folds) if by_cycle else float("nan")
        accepted = refused = False
        for c in cands:
            # keep trying: a candidate refused passes the turn to the next in rank
            spec, di = c.specs[0], c.column
            members = c.specs if len(c.specs) > 1 else ()
            p_adj = min(1.0, c.p * m)
            if p_adj >= alpha:
                if not refused:  # the best-ranked candidate the test refuses is reported
                    steps.append(
                        Step(
                            spec,
                            float(c.stat),
                            float(c.p),
                            float(p_adj),
                            m,
                            float("nan"),
                            float("nan"),
                            False,
                            (),
                            members,
                        )
                    )
                refused = True
                continue
            if spec.kind == "drift" and spec.shape == "saturating":
                spec = refine_tau(spec, layout, series, obs, Q, r)
            if spec.kind == "level":  # the step's cycle between the positions tried
                spec, _ = refine_level(
                    spec,
                    layout,
                    series,
                    obs,
                    Q,
                    r,
                    float(dense_scores(Q, r, effect_columns(spec, layout, series, obs))[0][0]),
                )
            if di <= -2:  # a per-register set: the members that earn their coefficient
                keep = prune_set(X, blocks[-2 - di], obs, n_cyc, alpha) if by_cycle else list(range(len(members)))
                cols = blocks[-2 - di][:, keep]
                members = tuple(members[i] for i in keep)
                spec = members[0]
                members = members if len(members) > 1 else ()
            elif di >= 0 and spec == specs[di]:
                cols = Z[:, [di]]
            else:
                cols = effect_columns(spec, layout, series, obs)
            X1 = np.hstack([X, cols])
            cv1 = float("nan")
            # a static term is the same on every cycle: its evidence is the dimensions' offsets (the test),
            # which held-out cycles cannot add to; time-dependent terms must also predict held-out cycles
            if by_cycle and spec.kind not in STATIC:
                cv1 = cv_sse(X1, obs.z, fold_of, folds)
                if not cv1 < cv0:
                    steps.append(Step(spec, float(c.stat), float(c.p), float(p_adj), m, cv0, cv1, False, (), members))
                    continue
            if di >= 0:
                same = alike(Q, cols[:, 0], Z, specs, active_dense, di, g)
            elif di == -1:
                same = relation_set(Q, r, obs, series.applied, layout, spec, alpha)
            else:
                same = alike_sets(Q, -2 - di, blocks, sets, active_set)
            steps.append(Step(spec, float(c.stat), float(c.p), float(p_adj), m, cv0, cv1, True, same, members))
            found += [spec] if not members else list(members)
            X = X1
            if di >= 0:
                active_dense[di] = False
                if spec.kind == "drift":  # one drift shape at most
                    active_dense &= np.array([s.kind != "drift" for s in specs])
            elif di == -1:
                active_rel[
                    layout.register_ids.index(str(spec.register)), layout.dimension_ids.index(str(spec.dimension))
                ] = False
            else:
                active_set[-2 - di] = False
            accepted = True
            n_accepted += 1
            break
        if not accepted:
            break
    if by_cycle and any(len(st.terms) > 1 for st in steps if st.accepted):
        found, steps, X = _reprune(layout, series, obs, declared, found, steps, alpha)
    lack = False
    if n_cyc >= 2:
        Q = orth(X)
        r = obs.z - Q @ (Q.T @ obs.z)
        n_static = obs.base.shape[1] + sum(s.kind in STATIC for s in (*declared, *found))
        lack = lack_of_fit(obs.dim, r, obs.n, n_static, alpha) is not None
        if lack:
            notes.append(
                "the dimensions keep constant offsets beyond the noise that no candidate explains "
                "(lack of fit): a register or relation the model lacks on single dimensions?"
            )
    notes += list(
        dict.fromkeys(
            f"{st.target}: ranked first in a step, but too few parts carry it to test {len(st.members)} coefficients "
            "per part (the set's test has no degrees of freedom left): not claimed"
            for st in steps
            if not st.accepted and len(st.members) > 1 and st.p >= 1.0 and st.f == 0.0
        )
    )
    notes += register_notes(layout, series, obs)
    return Selection(tuple(found), tuple(steps), tuple(dict.fromkeys(unident)), tuple(notes), lack)


def relation_candidate(
    layout: Layout,
    obs: Observations,
    gain_r: Array,
    slope_r: Array,
    active_rel: npt.NDArray[np.bool_],
    r: Array,
    rss0: float,
    df0: int,
    by_cycle: bool,
    lof: tuple[float, int] | None,
) -> Candidate | None:
    """The best relation of the step: the dimension most off (slope and constant), then the register whose
    changes it answers (slope); tested on two kinds of evidence, Bonferroni over both: the slope against that
    dimension's own variation over cycles, and, when the dimensions keep offsets, its free constant
    (δ · s_i on one dimension) against the lack of fit."""
    q_r = int(np.unravel_index(int(np.argmax(np.where(active_rel, gain_r, -1.0))), gain_r.shape)[1])
    i_r = int(np.argmax(np.where(active_rel[:, q_r], slope_r[:, q_r], -1.0)))
    if not active_rel[i_r, q_r]:
        return None
    spec = EffectSpec("relation", register=layout.register_ids[i_r], dimension=layout.dimension_ids[q_r])
    g_r = float(gain_r[i_r, q_r])
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
    return Candidate(rank_r, p_r, f_r, (spec,), -1)


def _reprune(
    layout: Layout,
    series: Series,
    obs: Observations,
    declared: tuple[EffectSpec, ...],
    found: list[EffectSpec],
    steps: list[Step],
    alpha: float,
) -> tuple[list[EffectSpec], list[Step], Array]:
    """Members of the per-register sets found pruned again with every other effect found in the model (a member
    that stood in for an effect found later drops out); returns the effects, the steps and the design."""

    def cols(terms: list[EffectSpec] | tuple[EffectSpec, ...]) -> Array:
        return np.hstack([obs.base] + [effect_columns(t, layout, series, obs) for t in (*declared, *terms)])

    out_steps = list(steps)
    for i, st in enumerate(steps):
        if not st.accepted or len(st.terms) < 2:
            continue
        terms = out_steps[i].terms
        others = [t for t in found if t not in terms]
        block = np.column_stack([effect_columns(t, layout, series, obs)[:, 0] for t in terms])
        keep = prune_set(cols(others), block, obs, series.n_cycles, alpha)
        kept = tuple(terms[j] for j in keep)
        found = [t for t in found if t not in terms or t in kept]
        out_steps[i] = dataclasses.replace(st, spec=kept[0], members=kept if len(kept) > 1 else ())
    return found, out_steps, cols(found)
