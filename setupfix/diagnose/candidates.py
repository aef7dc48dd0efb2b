"""The candidates a series allows: one-column terms, per-register process sets, refined positions.

Every candidate is a term on covariates the series carries (the kinds of
:data:`setupfix.diagnose.terms.KINDS`).  Most are one column; a *process set*
(:func:`process_sets`) is one recorded channel acting on every tool register with a
coefficient each (a designed factor that lengthens one cutter and shortens another):
one multi-column candidate, tested as a block (:func:`setupfix.diagnose.inference.cluster_wald`)
and reported as one ``process`` effect per register.  Level steps and saturating drifts are
tried on a grid and the accepted one refined (:func:`refine_level`, :func:`refine_tau`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.optimize

from setupfix.diagnose.fit import Observations, effect_columns
from setupfix.diagnose.scores import dense_scores
from setupfix.diagnose.support import STATIC, spread
from setupfix.diagnose.terms import AXES, EffectSpec, Layout, Series

__all__ = [
    "STATIC",
    "axis_positions",
    "candidate_specs",
    "process_sets",
    "level_positions",
    "refine_level",
    "refine_tau",
]

Array = npt.NDArray[np.float64]


def candidate_specs(
    layout: Layout,
    series: Series,
    *,
    taus: tuple[float, ...] = (0.1, 0.25, 0.5),
    max_positions: int = 32,
    min_side: int = 2,
) -> list[EffectSpec]:
    """Every one-column candidate the series' covariates allow (relations and process sets aside).

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
    out += axis_positions(layout)
    out += [EffectSpec("rotation", register=w) for w in layout.rotation_ids]
    for g in dict.fromkeys(g for g in layout.groups if g is not None):
        out.append(EffectSpec("group", group=g))
    targets: tuple[str | None, ...] = (None, *layout.register_ids)
    for k in level_positions(series, max_positions, min_side):
        cyc = series.cycles[k] if series.cycles else f"cycle {k + 1}"
        out += [EffectSpec("level", register=r, at=float(series.time[k]), cycle=cyc) for r in targets]
    for c, name in enumerate(series.channels):
        col = series.temperature[:, c]
        if n >= 3 and np.ptp(col) > 0 and name in process:
            ref = float(f"{np.mean(col):.4g}")
            out += [EffectSpec("process", channel=name, register=r, reference=ref) for r in targets]
    return out


def axis_positions(layout: Layout) -> list[EffectSpec]:
    """Position slopes per measuring axis of a multi-axis model: x-errors ∝ x, y-errors ∝ y, z-errors ∝ z.

    A slope a on one axis is that axis's scale (a plate measured warm along X, a scale error
    of the X axis): δ_q = a · n_q[a] · x_q[a].  Offered for an axis that at least three
    dimensions measure along and whose coordinates are spread (:func:`spread`) over them.
    """
    if layout.direction.shape[0] != layout.n_dimensions:
        return []
    out = []
    for a, axis in enumerate(AXES):
        along = np.abs(np.nan_to_num(layout.direction[:, a])) > 0.5
        col = layout.coord[along, a]
        if along.sum() >= 3 and np.isfinite(col).all() and spread(col):
            out.append(EffectSpec("position", axis=axis, along=axis))
    return out


def process_sets(layout: Layout, series: Series) -> list[tuple[EffectSpec, ...]]:
    """Per-register process candidates: every process channel on every tool register, a coefficient each.

    Offered when the log has a channel that moves and the model has at least two tool
    registers that move a dimension; each set is one candidate of ``len(set)`` columns
    (the channel's reference is its mean, as for the one-register candidates).
    """
    n = series.n_cycles
    tools = [layout.register_ids[j] for j in layout.tools if np.any(layout.composite[j] != 0)]
    if n < 3 or len(tools) < 2:
        return []
    process = set(series.process_channels)
    out: list[tuple[EffectSpec, ...]] = []
    for c, name in enumerate(series.channels):
        col = series.temperature[:, c]
        if name in process and np.ptp(col) > 0:
            ref = float(f"{np.mean(col):.4g}")
            out.append(tuple(EffectSpec("process", channel=name, register=r, reference=ref) for r in tools))
    return out


def level_positions(series: Series, max_positions: int, min_side: int) -> list[int]:
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


def refine_level(
    spec: EffectSpec,
    layout: Layout,
    series: Series,
    obs: Observations,
    Q: Array,
    r: Array,
    gain: float,
    min_side: int = 2,
) -> tuple[EffectSpec, float]:
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
    alts = [
        EffectSpec(
            "level",
            register=spec.register,
            at=float(t[k]),
            cycle=series.cycles[int(order[k])] if series.cycles else f"cycle {int(order[k]) + 1}",
        )
        for k in ks
    ]
    g = dense_scores(Q, r, np.column_stack([effect_columns(a, layout, series, obs)[:, 0] for a in alts]))[0]
    best = int(np.argmax(g))
    return (alts[best], float(g[best])) if g[best] > gain else (spec, gain)


def refine_tau(spec: EffectSpec, layout: Layout, series: Series, obs: Observations, Q: Array, r: Array) -> EffectSpec:
    """Time constant of a saturating drift refined by a bounded 1-D search on the residual."""
    span = float(np.ptp(series.time))

    def loss(log_tau: float) -> float:
        s = EffectSpec("drift", shape="saturating", tau=float(np.exp(log_tau)))
        return -float(dense_scores(Q, r, effect_columns(s, layout, series, obs))[0][0])

    res = scipy.optimize.minimize_scalar(
        loss, bounds=(np.log(0.02 * span), np.log(2.0 * span)), method="bounded", options={"xatol": 1e-3}
    )
    tau = float(np.exp(res.x)) if res.fun < loss(np.log(spec.tau)) else spec.tau
    return EffectSpec("drift", shape="saturating", tau=float(f"{tau:.4g}"))
