"""Declared design factors: the hypotheses of a designed experiment, tested as stated, not searched for.

A process engineer who ran a designed experiment (tool stick-out × spindle speed, say)
knows its factors before the data come in.  Testing them as such is one family of
hypotheses stated in advance, not a search over every channel, register and level
position, and it pays only for that family.  Here a *term* is a factor of the process log
(``doe_speed``: a numeric channel, or a categorical one with its 0/1 level indicators
``doe_speed=Low``, …) or an interaction of factors (``doe_tool_length*doe_speed``: the
products of their columns, channels joined by :data:`~setupfix.diagnose.terms.PRODUCT`).

Each declared term is tested on each tool register (every register when the model has
no tools) that moves a dimension, a coefficient per column (its levels but one, for a
categorical factor) — the per-register ``process`` effect of
:mod:`setupfix.diagnose.candidates` with the columns fixed in advance:

* the columns of a term are those of its channels that add to the rank of the per-cycle
  design built so far (a constant, then the main effects, then the interactions, in the
  order declared): the first level of a factor is the reference, an interaction adds only
  what its main effects do not hold; a level seen on fewer than :data:`MIN_LEVEL_PARTS`
  parts (off-design runs) gets its own constant, fitted but not tested;
* the block of a term on register j is tested in the model of the declared model (its
  ``[effects]``) plus every declared term of the same or lower order on every register
  but that block (type II: main effects adjusted for each other, interactions for the main
  effects), by the multi-column cluster-robust Wald test with the part as the cluster
  (:func:`setupfix.diagnose.inference.cluster_wald`, Hotelling-scaled F), each part's
  residual corrected for its leverage (CR2) and Bell–McCaffrey degrees of freedom: a cell
  of a design sits on few parts, and the plain variance (CR1) underrates them;
* the family is the declared terms × registers, and Holm's step-down procedure
  (Holm 1979) holds its family-wise error at ``alpha``: p₍ᵢ₎ (m − i + 1), running maximum.

A term accepted on a register enters the fit with the lower-order terms it contains (on
that register: an interaction is read relative to its main effects).  The search of
:mod:`setupfix.diagnose.select` then runs with them in its base.  Calibration:
``bench/diagnose_factors.py`` (declared factors with no effect: the plate's log rows
permuted across whole parts, and simulated series with a random 2 × 3 design).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.fit import Observations, effect_columns, observations
from setupfix.diagnose.inference import MIN_CYCLES, cluster_wald, orth
from setupfix.diagnose.terms import PRODUCT, EffectSpec, Layout, Series, channel_values

__all__ = [
    "INTERACTION",
    "Term",
    "FactorTest",
    "FactorTests",
    "parse_terms",
    "factor_channels",
    "term_columns",
    "factor_tests",
    "holm",
    "registers_moving",
]

Array = npt.NDArray[np.float64]

#: Separator of an interaction's factors as declared (``doe_tool_length*doe_speed``).
INTERACTION = "*"


@dataclass(frozen=True)
class Term:
    """A declared term: one factor (a main effect) or several (their interaction)."""

    factors: tuple[str, ...]

    @property
    def name(self) -> str:
        return INTERACTION.join(self.factors)

    @property
    def order(self) -> int:
        return len(self.factors)


def parse_terms(declared: str | tuple[str, ...] | list[str]) -> tuple[Term, ...]:
    """Terms from ``a,b,a*b`` (or a sequence of such strings); duplicates once, in the order given.

    Raises
    ------
    ValueError
        If a term or a factor name is empty or a factor appears twice in one term.
    """
    items = [declared] if isinstance(declared, str) else list(declared)
    out: list[Term] = []
    for text in (t.strip() for item in items for t in item.split(",")):
        factors = tuple(f.strip() for f in text.split(INTERACTION))
        if not text or not all(factors):
            raise ValueError(f"empty factor name in {text!r}" if text else "empty term")
        if len(set(factors)) < len(factors):
            raise ValueError(f"a factor appears twice in {text!r}")
        term = Term(factors)
        if term not in out:
            out.append(term)
    return tuple(out)


def factor_channels(series: Series, factor: str) -> tuple[str, ...]:
    """The process channels of one factor: the numeric channel of that name, or its level indicators.

    Raises
    ------
    KeyError
        If the series has no such channel (the message names it).
    """
    chans = tuple(
        c for c in series.process_channels if c == factor or (c.startswith(factor + "=") and PRODUCT not in c)
    )
    if not chans:
        raise KeyError(factor)
    return chans


#: Leverage correction of the declared tests' variance (:func:`~setupfix.diagnose.inference.cluster_wald`).
POWER = 0.5

#: A factor's level seen on fewer parts than this is fitted (its own constant) but not tested.
MIN_LEVEL_PARTS = 3


def _rare(v: Array) -> bool:
    """A 0/1 level indicator on fewer than :data:`MIN_LEVEL_PARTS` parts."""
    return bool(np.isin(v, (0.0, 1.0)).all() and 0 < v.sum() < MIN_LEVEL_PARTS)


def term_columns(series: Series, terms: tuple[Term, ...]) -> dict[Term, tuple[tuple[str, ...], tuple[str, ...]]]:
    """The channels each term keeps, tested and fitted only: those that add to the rank of the per-cycle design.

    ``terms`` are taken lower orders first.  Per term, the channels that hold a level seen on fewer
    than :data:`MIN_LEVEL_PARTS` parts (off-design runs, e.g. the operator's choice) come first and
    are fitted only (too few parts to test them by), then the others, tested; one level of a
    factor is the reference, an interaction keeps what its main effects do not hold.
    """
    n = series.n_cycles
    design = np.ones((n, 1)) / np.sqrt(max(n, 1))
    rank = 1
    out: dict[Term, tuple[tuple[str, ...], tuple[str, ...]]] = {}
    for term in sorted(terms, key=lambda t: t.order):
        combos = [PRODUCT.join(c) for c in itertools.product(*(factor_channels(series, f) for f in term.factors))]
        rare = {c for c in combos if any(_rare(channel_values(series, p)) for p in c.split(PRODUCT))}
        kept: dict[bool, list[str]] = {True: [], False: []}
        # the first level of each factor is the reference: tried last, it is the one that adds nothing
        for name in sorted(reversed(combos), key=lambda c: c not in rare):
            v = channel_values(series, name)
            v = v - v.mean()
            norm = float(np.linalg.norm(v))
            if norm == 0.0:
                continue
            trial = np.column_stack([design, v / norm])
            r = int(np.linalg.matrix_rank(trial, tol=1e-8))
            if r > rank:
                design, rank = trial, r
                kept[name not in rare].append(name)
        out[term] = (tuple(sorted(kept[True], key=combos.index)), tuple(sorted(kept[False], key=combos.index)))
    return out


@dataclass(frozen=True)
class FactorTest:
    """One declared term on one register: its per-part test and the Holm-adjusted p."""

    term: Term
    register: str
    specs: tuple[EffectSpec, ...]
    f: float
    p: float
    p_holm: float
    q: int
    accepted: bool


@dataclass(frozen=True)
class FactorTests:
    """The declared family's tests, and the effect terms they put in the model.

    Attributes
    ----------
    terms : tuple of Term
        As declared.
    tests : tuple of FactorTest
        One per term × register, in that order.
    found : tuple of EffectSpec
        The accepted blocks with the lower-order terms they contain, per register.
    notes : tuple of str
    family : str
        ``declared`` (``--factors``) or ``log`` (the process log's own columns,
        :mod:`setupfix.diagnose.log_family`): the ``source`` of the effects found.
    """

    terms: tuple[Term, ...]
    tests: tuple[FactorTest, ...]
    found: tuple[EffectSpec, ...]
    notes: tuple[str, ...] = ()
    family: str = "declared"

    def test_of(self, spec: EffectSpec) -> FactorTest | None:
        """The accepted test whose block holds ``spec`` (None for a term fitted with an accepted interaction)."""
        return next((t for t in self.tests if t.accepted and spec in t.specs), None)


def registers_moving(layout: Layout) -> list[int]:
    """The tool registers that move a dimension (every such register when the model has no tools)."""
    moving = [j for j in layout.tools if np.any(layout.composite[j] != 0)]
    return moving or [j for j in range(layout.n_registers) if np.any(layout.composite[j] != 0)]


def holm(p: Array) -> Array:
    """Holm's step-down adjusted p-values (Holm 1979): max over i' ≤ i of p₍ᵢ'₎ (m − i' + 1), at most 1."""
    order = np.argsort(p, kind="stable")
    m = p.size
    adj = np.maximum.accumulate(p[order] * (m - np.arange(m)))
    out = np.empty(m)
    out[order] = np.minimum(adj, 1.0)
    return out


def factor_tests(
    layout: Layout,
    series: Series,
    terms: tuple[Term, ...],
    *,
    alpha: float = 0.01,
    obs: Observations | None = None,
    declared: tuple[EffectSpec, ...] = (),
) -> FactorTests:
    """Test the declared terms per register with the part as the unit; Holm over the family (module text).

    Parameters
    ----------
    layout, series
    terms : tuple of Term
        The declared terms; the main effects an interaction contains are fitted with it even
        when not declared (not tested then).
    alpha : float
        Family-wise level over the declared terms × registers.
    obs : Observations, optional
    declared : tuple of EffectSpec
        The model's own effects (part of every test's base).

    Returns
    -------
    FactorTests

    Raises
    ------
    KeyError
        If a factor is no process channel of the series.
    """
    obs = observations(layout, series) if obs is None else obs
    model_terms = list(terms)
    for t in terms:
        model_terms += [Term((f,)) for f in t.factors if t.order > 1 and Term((f,)) not in model_terms]
    chans = term_columns(series, tuple(model_terms))
    regs = registers_moving(layout)
    specs: dict[tuple[Term, int, bool], tuple[EffectSpec, ...]] = {}
    cols: dict[tuple[Term, int, bool], Array] = {}
    for t in model_terms:
        for j in regs:
            for tested in (True, False):  # the block tested, the rare levels fitted only
                sp = tuple(
                    EffectSpec(
                        "process",
                        channel=c,
                        register=layout.register_ids[j],
                        reference=float(f"{np.mean(channel_values(series, c)):.4g}"),
                    )
                    for c in chans[t][not tested]
                )
                specs[(t, j, tested)] = sp
                cols[(t, j, tested)] = (
                    np.hstack([effect_columns(s, layout, series, obs) for s in sp]) if sp else np.zeros((obs.n, 0))
                )
    base = np.hstack([obs.base] + [effect_columns(s, layout, series, obs) for s in declared])
    notes: list[str] = []
    by_part = series.n_cycles >= MIN_CYCLES
    if not by_part:
        notes.append(f"declared factors: {series.n_cycles} cycle(s), too few to test per part: none accepted")
    raw: list[tuple[Term, int, float, float, int]] = []
    for t in terms:
        for j in regs:
            block = cols[(t, j, True)]
            if not by_part or block.shape[1] == 0:
                raw.append((t, j, 0.0, 1.0, 0))
                continue
            context = [
                cols[(u, i, b)]
                for u in model_terms
                if u.order <= t.order
                for i in regs
                for b in (True, False)
                if (u, i, b) != (t, j, True)
            ]
            Q = orth(np.hstack([base, *context]))
            r = obs.z - Q @ (Q.T @ obs.z)
            f, p, q = cluster_wald(block - Q @ (Q.T @ block), r, obs.cycle, series.n_cycles, Q=Q, power=POWER)
            raw.append((t, j, f, p, q))
    for t in terms:
        if not chans[t][0]:
            notes.append(f"declared factor {t.name}: its channels do not vary beyond the terms before it: not testable")
    adj = holm(np.array([x[3] for x in raw])) if raw else np.zeros(0)
    tests = tuple(
        FactorTest(t, layout.register_ids[j], specs[(t, j, True)], f, p, float(a), q, bool(a < alpha and q > 0))
        for (t, j, f, p, q), a in zip(raw, adj, strict=True)
    )
    keep: set[tuple[Term, int]] = set()
    for x in tests:
        if x.accepted:
            j = layout.register_ids.index(x.register)
            keep.add((x.term, j))
            keep |= {(Term((fa,)), j) for fa in x.term.factors if x.term.order > 1}
    found = tuple(
        s
        for t in sorted(model_terms, key=lambda t: t.order)
        for j in regs
        if (t, j) in keep
        for b in (False, True)
        for s in specs[(t, j, b)]
    )
    return FactorTests(tuple(terms), tests, found, tuple(notes))
