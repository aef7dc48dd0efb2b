"""What a series can support: static slopes need spread, registers need to have moved apart.

Support rules for the static kinds (:func:`spread`): a scale effect needs at least three
distinct nominal sizes spread over their range, a position effect a spread of feature
positions along its axis; otherwise the candidate is not offered and the notes say why
(:func:`support_notes`).  Diagnosability of the registers from the applied corrections
(:func:`register_notes`): never corrected, always moved together, null space of C;
candidates the series cannot tell apart (:func:`alike`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.correction.relation import null_space_directions
from setupfix.diagnose.fit import Observations
from setupfix.diagnose.terms import AXES, EffectSpec, Layout, Series

__all__ = ["STATIC", "spread", "support_notes", "register_notes", "alike", "alike_sets"]

Array = npt.NDArray[np.float64]

_TINY = 1e-9

#: Kinds whose field is the same on every cycle.
STATIC = ("scale", "position", "rotation", "group")


def spread(values: Array) -> bool:
    """Support of a static slope: ≥ 3 distinct values and one in each third of their range.

    A scale effect on what are in effect two nominal sizes (or a position effect on two
    clusters of features) is one contrast between two groups, not a slope: a group
    offset or a relation would fit it as well.
    """
    v = np.unique(np.round(np.asarray(values, dtype=float), 9))
    if v.size < 3 or not np.isfinite(v).all():
        return False
    lo, hi = float(v[0]), float(v[-1])
    third = np.minimum((3 * (v - lo) / (hi - lo)).astype(int), 2)
    return bool(np.unique(third).size == 3)


def support_notes(layout: Layout) -> list[str]:
    """Why a static kind is not offered: nominal sizes or positions without spread."""
    notes: list[str] = []
    if np.ptp(layout.nominal) > 0 and not spread(layout.nominal):
        notes.append(
            "scale not tested: the nominal sizes are not spread over their range (needs at least three "
            "distinct sizes, one in each third of the range)"
        )
    for a, axis in enumerate(AXES):
        col = layout.coord[:, a]
        if np.isfinite(col).all() and np.ptp(col) > 0 and not spread(col):
            notes.append(
                f"position {axis} not tested: the features' {axis} positions are not spread over their "
                "range (needs at least three distinct, one in each third of the range)"
            )
    return notes


def register_notes(layout: Layout, series: Series, obs: Observations) -> list[str]:
    """Diagnosability of the registers from the applied corrections."""
    notes: list[str] = []
    u = series.applied - series.applied.mean(axis=0) if series.n_cycles else series.applied
    moved = np.ptp(series.applied, axis=0) > _TINY if series.n_cycles else np.zeros(layout.n_registers, bool)
    ids = layout.register_ids
    if series.n_cycles >= 3:
        still = [ids[i] for i in np.flatnonzero(~moved)]
        if still:
            notes.append(
                "never corrected during the series, so how dimensions answer them cannot be checked: "
                + ", ".join(still)
            )
        idx = np.flatnonzero(moved)
        for a_pos, a in enumerate(idx):
            for b in idx[a_pos + 1 :]:
                na, nb = np.linalg.norm(u[:, a]), np.linalg.norm(u[:, b])
                if abs(u[:, a] @ u[:, b]) > (1 - 1e-6) * na * nb:
                    notes.append(
                        f"{ids[a]} and {ids[b]} always moved together: a wrong relation of one "
                        "cannot be told from the other"
                    )
    for row in null_space_directions(layout.composite):
        terms = " ".join(
            f"{'+' if v > 0 else '-'}{'' if abs(v) == 1 else f'{abs(v):g}·'}{ids[i]}"
            for i, v in enumerate(row)
            if v != 0
        )
        notes.append(f"the setup state is known only up to {terms.lstrip('+')} (moves no dimension)")
    return notes


def alike(
    Q: Array,
    col: Array,
    Z: Array,
    specs: list[EffectSpec],
    active: npt.NDArray[np.bool_],
    chosen: int,
    norms2: Array,
    threshold: float = 0.98,
) -> tuple[str, ...]:
    """Candidates whose residualised columns are nearly collinear with the chosen one.

    ``norms2`` holds the residualised columns' squared norms (as :func:`~setupfix.diagnose.scores.dense_scores`
    gives them): with c the chosen column residualised on Q, the correlation of column j is
    |Z_jᵀc| / (‖Z_j − QQᵀZ_j‖ ‖c‖), no residualised copy of Z formed.
    """
    if Z.shape[1] == 0:
        return ()
    c = col - Q @ (Q.T @ col)
    num = np.abs(Z.T @ c)
    den = np.sqrt(np.maximum(norms2, 0.0)) * np.linalg.norm(c)
    corr = np.where(den > _TINY, num / np.where(den > _TINY, den, 1.0), 0.0)
    return tuple(
        f"{specs[i].kind}: {specs[i].target}" for i in np.flatnonzero((corr > threshold) & active) if i != chosen
    )


def alike_sets(
    Q: Array,
    chosen: int,
    blocks: list[Array],
    sets: list[tuple[EffectSpec, ...]],
    active: npt.NDArray[np.bool_],
    threshold: float = 0.98,
) -> tuple[str, ...]:
    """Per-register sets whose residualised blocks span nearly the same space as the chosen one's (every
    principal angle's cosine above ``threshold``): channels the series cannot tell apart per register."""

    def basis(B: Array) -> Array:
        P = B - Q @ (Q.T @ B)
        u, sv, _ = np.linalg.svd(P, full_matrices=False)
        out: Array = u[:, sv > 1e-9 * max(1.0, float(sv.max(initial=0.0)))]
        return out

    a = basis(blocks[chosen])
    out = []
    for i in np.flatnonzero(active):
        if i == chosen:
            continue
        b = basis(blocks[i])
        if b.shape[1] != a.shape[1] or a.shape[1] == 0:
            continue
        if float(np.linalg.svd(a.T @ b, compute_uv=False).min()) > threshold:
            regs = ", ".join(str(t.register) for t in sets[i])
            out.append(f"process: {regs} ~ {sets[i][0].channel} (a coefficient each)")
    return tuple(out)
