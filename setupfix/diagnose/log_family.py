"""The process log's own columns as the user's family of hypotheses, tested before the broad search.

A process log given without ``--factors`` still says what the user suspects: each of its
columns (a numeric channel, or a categorical one with its 0/1 level indicators) is a
hypothesis stated in advance.  Weighing them among the search's hundreds of candidates
pays for every channel × register × level position; testing every column and its
interactions at once (type II, as :func:`~setupfix.diagnose.factors.factor_tests` does
for a declared design) leaves no degrees of freedom: ten columns on five tools is more
coefficients than twenty parts can carry.  So the family is tested hierarchically, by
forward selection inside it:

1. main effects.  Step k tests every column not yet accepted on every register that moves
   a dimension (tool or work offset: the per-register ``process`` effect of
   :mod:`setupfix.diagnose.candidates`), given the model's ``[effects]`` and the blocks
   accepted so far.  The statistic is what the block explains; its null is the log's rows
   dealt to the parts at random (B seeded permutations, the same for every test of the
   step), so shared per-part noise and a part's many cells are the permutation's to carry,
   not an assumption's.  The step's family is its tests only (the remaining columns ×
   registers) with the single-step max-T adjustment of Westfall & Young (1993) on each
   statistic scaled by its permutation mean (:func:`max_t`): exact when the parts are
   exchangeable, and it keeps the dependence of one log on every register where Holm's
   bound (:func:`~setupfix.diagnose.factors.holm`) pays for it as if independent.  When the
   smallest adjusted p is below ``alpha`` its column is taken, on the register where it
   explains the most (a tool's effect leaks into a work offset sharing some of its
   dimensions, where it can rank first: the search's ranking by what each explains); the
   accepted test carries that smallest adjusted p; the next step starts;
2. interactions, of a column accepted on a register with any other column on that register
   (weak heredity: the product columns the main effects do not hold,
   :func:`~setupfix.diagnose.factors.term_columns`, with both main effects fitted there),
   by the same rule;
3. it stops when a step accepts nothing.

The cluster-robust Wald test of a declared design (CR2, Bell–McCaffrey df) is too
conservative for this family: a column on three of twenty parts leaves it few degrees of
freedom, and Holm over some forty tests (every column at once, type II) refuses the plate's
stick-out × speed on T5A (p 0.0013, Holm 0.048: ``bench/diagnose_log_family.py`` A).

The columns of a candidate on register j are those that add to the rank of the per-cycle
design of the terms accepted on j (one level of a categorical column is the reference; a
level on fewer than :data:`~setupfix.diagnose.factors.MIN_LEVEL_PARTS` parts is fitted, not
tested).  A block taken first is tested again once the search's effects are in the model
(:func:`log_recheck`).  Calibration (the log's rows permuted across the parts: no claim in ≥ 95 % of runs) and the
NIST plate: ``bench/diagnose_log_family.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.factors import (
    FactorTest,
    FactorTests,
    Term,
    term_columns,
)
from setupfix.diagnose.fit import Observations, effect_columns, observations
from setupfix.diagnose.inference import MIN_CYCLES, orth
from setupfix.diagnose.terms import PRODUCT, EffectSpec, Layout, Series, channel_values

__all__ = ["LOG_FAMILY", "PERMUTATIONS", "log_factors", "log_family", "log_recheck", "max_t", "permutation_gains"]

Array = npt.NDArray[np.float64]

#: :attr:`FactorTests.family` of the log's own columns (the effects' ``source``).
LOG_FAMILY = "log"

#: Permutations of the cycles per selection step (the smallest adjusted p is 1 / (PERMUTATIONS + 1)).
PERMUTATIONS = 999


def log_factors(series: Series) -> tuple[str, ...]:
    """The process log's columns, in the log's order: a numeric channel, or a categorical column's name
    (its ``name=level`` indicators); the reader's product channels (``a=x & b=y``) are no column."""
    names = (c.split("=", 1)[0] if "=" in c else c for c in series.process_channels if PRODUCT not in c)
    return tuple(dict.fromkeys(names))


def _specs(layout: Layout, series: Series, channels: tuple[str, ...], j: int) -> tuple[EffectSpec, ...]:
    return tuple(
        EffectSpec(
            "process",
            channel=c,
            register=layout.register_ids[j],
            reference=float(f"{np.mean(channel_values(series, c)):.4g}"),
        )
        for c in channels
    )


def permutation_gains(values: Array, a: Array, G: Array, perms: npt.NDArray[np.intp]) -> Array:
    """What a block explains, ``rᵀ Z (ZᵀZ)⁺ Zᵀ r``, for its per-cycle values as observed and permuted.

    The block's design is ``Z = M V`` with ``V`` (n_cycles, q) the per-cycle values and ``M``
    (N, n_cycles) the register's pattern on each cycle's cells, residualised on the current
    model; ``a = Mᵀ r`` and ``G = Mᵀ M`` hold what is needed, so that a permutation π of the
    cycles costs O(n² q): ``(V_πᵀ a)ᵀ (V_πᵀ G V_π)⁺ (V_πᵀ a)``.

    Parameters
    ----------
    values : ndarray (n_cycles, q)
    a : ndarray (n_cycles,)
    G : ndarray (n_cycles, n_cycles)
    perms : ndarray of int (B, n_cycles)
        Row orders; the observed order is not implied.

    Returns
    -------
    ndarray (B + 1,)
        The observed gain first, then one per permutation [model unit²].
    """
    V = np.concatenate([values[None], values[perms]])  # (B + 1, n, q)
    u = np.einsum("bnq,n->bq", V, a)
    S = np.einsum("bnq,nm,bmp->bqp", V, G, V)
    sol = np.einsum("bqp,bp->bq", np.linalg.pinv(S, hermitian=True), u)
    out: Array = np.einsum("bq,bq->b", u, sol)
    return out


def max_t(gains: Array) -> tuple[Array, Array]:
    """Per-test permutation p-values and their single-step max-T adjustment (Westfall & Young 1993).

    Parameters
    ----------
    gains : ndarray (B + 1, T)
        Statistic of each of T tests for the observed order (row 0) and B joint permutations.

    Returns
    -------
    p, p_adjusted : ndarray (T,)
        Each test's statistic is scaled by its mean over the B + 1 orders (what the block
        explains by chance: the tests become comparable whatever their columns and register),
        s_bt = g_bt / mean_b g_bt; p_t = #{b: s_bt ≥ s_0t} / (B + 1) and the adjusted
        #{b: max_t' s_bt' ≥ s_0t} / (B + 1).  The observed order is one of B + 1 equally
        likely under exchangeable cycles, so both are exact; the maximum keeps the family's
        dependence (one log on every register) where Holm assumes the worst.
    """
    n_all = gains.shape[0]
    s = gains / np.maximum(gains.mean(axis=0), 1e-300)
    tol = 1e-9 * np.maximum(s.max(axis=0), 1.0)
    p = np.sum(s >= s[0] - tol, axis=0) / float(n_all)
    top = s.max(axis=1)
    adj = np.sum(top[:, None] >= s[0][None, :] - tol, axis=0) / float(n_all)
    return p, adj


def log_family(
    layout: Layout,
    series: Series,
    *,
    alpha: float = 0.01,
    obs: Observations | None = None,
    declared: tuple[EffectSpec, ...] = (),
    permutations: int = PERMUTATIONS,
    seed: int = 0,
) -> FactorTests:
    """Test the log's columns, then their interactions, by forward selection inside the family (module text).

    Parameters
    ----------
    layout, series
        The series' process channels are the family (none: an empty result).
    alpha : float
        Family-wise level of each step (max-T over that step's tests).
    obs : Observations, optional
    declared : tuple of EffectSpec
        The model's own effects (part of every test's base).
    permutations : int
        Permutations of the cycles per step (the same for every test of the step).
    seed : int
        Seed of the permutations.

    Returns
    -------
    FactorTests
        ``terms`` the columns, ``tests`` every step's tests in order (``f`` the plain F of
        the block, ``p`` its permutation p, ``p_holm`` adjusted over its step by max-T),
        ``found`` the accepted blocks with the main effects an interaction holds, per register,
        ``family`` :data:`LOG_FAMILY`.
    """
    obs = observations(layout, series) if obs is None else obs
    factors = log_factors(series)
    mains = tuple(Term((f,)) for f in factors)
    if not mains:
        return FactorTests((), (), (), (), family=LOG_FAMILY)
    if series.n_cycles < MIN_CYCLES:
        note = f"process log: {series.n_cycles} cycle(s), too few to test its columns per part: none accepted"
        return FactorTests(mains, (), (), (note,), family=LOG_FAMILY)
    regs = [j for j in range(layout.n_registers) if np.any(layout.composite[j] != 0)]  # tools and work offsets
    n = series.n_cycles
    rng = np.random.default_rng(seed)
    base = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in declared])
    on: dict[int, list[Term]] = {j: [] for j in regs}  # the terms in the model per register, lower orders first
    fitted: list[EffectSpec] = []  # every accepted block with its fitted-only levels
    tests: list[FactorTest] = []
    pattern = {
        j: np.where(obs.cycle[:, None] == np.arange(n)[None, :], layout.composite[j][obs.dim][:, None], 0.0)
        for j in regs
    }  # (N, n): register j's row on each cycle's cells

    def cols(specs: tuple[EffectSpec, ...]) -> Array:
        return np.hstack([effect_columns(s, layout, series, obs) for s in specs]) if specs else np.zeros((obs.n, 0))

    def candidate(term: Term, j: int) -> tuple[tuple[EffectSpec, ...], tuple[EffectSpec, ...]]:
        """(fitted-only, tested) specs of ``term`` on register j given the terms there (and its main effects)."""
        extra = [Term((f,)) for f in term.factors if term.order > 1 and Term((f,)) not in on[j]]
        chans = term_columns(series, (*on[j], *extra, term))
        rare = tuple(c for t in extra for c in (*chans[t][0], *chans[t][1])) + chans[term][1]
        return _specs(layout, series, rare, j), _specs(layout, series, chans[term][0], j)

    for order in (1, 2):
        while True:
            if order == 1:
                pool = [(t, j) for t in mains for j in regs if t not in on[j]]
            else:  # an interaction of a column accepted on the register with any other column (weak heredity)
                pool = list(
                    dict.fromkeys(
                        (Term(tuple(sorted((a.factors[0], b), key=factors.index))), j)
                        for j in regs
                        for a in on[j]
                        if a.order == 1
                        for b in factors
                        if b != a.factors[0]
                    )
                )
                pool = [(t, j) for t, j in pool if t not in on[j]]
            perms = np.argsort(rng.random((permutations, n)), axis=1)
            step: list[tuple[Term, int, tuple[EffectSpec, ...], tuple[EffectSpec, ...], float, int]] = []
            gains: list[Array] = []
            for t, j in pool:
                rare, block_specs = candidate(t, j)
                if not block_specs:
                    continue
                Q = orth(np.hstack([base, cols(tuple(fitted)), cols(rare)]))
                r = obs.z - Q @ (Q.T @ obs.z)
                M = pattern[j] - Q @ (Q.T @ pattern[j])
                V = np.column_stack([channel_values(series, str(s.channel)) for s in block_specs])
                g = permutation_gains(V - V.mean(axis=0), M.T @ r, M.T @ M, perms)
                q = len(block_specs)
                df = obs.n - Q.shape[1] - q
                rss = float(r @ r)
                f = (g[0] / q) / max((rss - g[0]) / max(df, 1), 1e-300)
                step.append((t, j, rare, block_specs, float(f), q))
                gains.append(g)
            if not step:
                break
            p, adj = max_t(np.column_stack(gains))
            best = int(np.argmin(adj - 1e-9 * np.array([x[4] for x in step])))  # ties: the larger F
            ok = bool(adj[best] < alpha)
            column_p = float(adj[best])
            if ok:  # the column is related: take it on the register where it explains the most
                same = [i for i, x in enumerate(step) if x[0] == step[best][0]]
                best = max(same, key=lambda i: (step[i][4], -adj[i]))
                adj[best] = column_p  # what was tested: the column, through the registers
            tests += [
                FactorTest(t, layout.register_ids[j], sp, f, float(pi), float(a), q, ok and i == best)
                for i, ((t, j, _, sp, f, q), pi, a) in enumerate(zip(step, p, adj, strict=True))
            ]
            if not ok:
                break
            t, j, rare, block_specs = step[best][:4]
            on[j] += [Term((fa,)) for fa in t.factors if t.order > 1 and Term((fa,)) not in on[j]] + [t]
            fitted += [*block_specs, *rare]  # the tested columns first, then what is fitted with them
    # lower orders first (an interaction after the main effects it holds)
    found = tuple(sorted(fitted, key=lambda s: PRODUCT in str(s.channel)))
    return FactorTests(mains, tuple(tests), found, (), family=LOG_FAMILY)


def log_recheck(
    layout: Layout,
    series: Series,
    family: FactorTests,
    others: tuple[EffectSpec, ...],
    *,
    alpha: float = 0.01,
    obs: Observations | None = None,
    declared: tuple[EffectSpec, ...] = (),
    permutations: int = PERMUTATIONS,
    seed: int = 0,
) -> FactorTests:
    """The family's accepted blocks tested again once the broad search's effects are in the model.

    A log column that tracks time (a setting changed in blocks) can stand in for a step or a
    drift the search finds afterwards; the parts, permuted, are no longer exchangeable then.
    Each accepted block is tested given every other effect (``others`` and the rest of the
    family) by the same permutation statistic, unadjusted; the worst is dropped while its p is
    at least ``alpha`` (a main effect is kept while an interaction on its register holds it).

    Returns
    -------
    FactorTests
        ``family`` with the dropped tests no longer accepted, ``found`` without their columns,
        and a note per dropped block.
    """
    obs = observations(layout, series) if obs is None else obs
    kept = [t for t in family.tests if t.accepted]
    if not kept or not others or series.n_cycles < MIN_CYCLES:
        return family
    n = series.n_cycles
    rng = np.random.default_rng(seed + 1)
    base = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in (*declared, *others)])
    dropped: list[tuple[FactorTest, float]] = []
    while kept:
        held = {(t.register, f) for t in kept if t.term.order > 1 for f in t.term.factors}
        testable = [t for t in kept if not (t.term.order == 1 and (t.register, t.term.factors[0]) in held)]
        if not testable:
            break
        gone = {s for t, _ in dropped for s in t.specs}
        perms = np.argsort(rng.random((permutations, n)), axis=1)
        gains = []
        for t in testable:
            j = layout.register_ids.index(t.register)
            ctx = [s for s in family.found if s not in gone and s not in t.specs]
            X = np.hstack([base] + [effect_columns(s, layout, series, obs) for s in ctx])
            Q = orth(X)
            r = obs.z - Q @ (Q.T @ obs.z)
            pat = np.where(obs.cycle[:, None] == np.arange(n)[None, :], layout.composite[j][obs.dim][:, None], 0.0)
            M = pat - Q @ (Q.T @ pat)
            V = np.column_stack([channel_values(series, str(s.channel)) for s in t.specs])
            gains.append(permutation_gains(V - V.mean(axis=0), M.T @ r, M.T @ M, perms))
        p, _ = max_t(np.column_stack(gains))
        worst = int(np.argmax(p))
        if p[worst] < alpha:
            break
        dropped.append((testable[worst], float(p[worst])))
        kept.remove(testable[worst])
    if not dropped:
        return family
    gone = {s for t, _ in dropped for s in t.specs}
    kept_regs = {t.register for t in kept}
    tested = {s for t in family.tests if t.accepted for s in t.specs}
    found = tuple(s for s in family.found if s not in gone and (s in tested or s.register in kept_regs))
    out = {id(t) for t, _ in dropped}
    tests = tuple(dataclasses.replace(t, accepted=False) if id(t) in out else t for t in family.tests)
    what = ", ".join(s.target for s in others[:3]) + (" …" if len(others) > 3 else "")
    notes = tuple(
        f"process log: {t.term.name} on {t.register} taken first, then not needed once the search's "
        f"{what} is in the model (p {p:.2g}): dropped"
        for t, p in dropped
    )
    return dataclasses.replace(family, tests=tests, found=found, notes=family.notes + notes)
