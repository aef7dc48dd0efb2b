"""What an ``[effects]`` section predicts until the next cycle (used by ``correct``).

A measured report shows the part as it was cut; the correction acts on the next
cycle.  Between the two, a drift goes on for one cycle interval and every tool wears
by one more cycle; the static effects (scale, position, group) are already in the
measured deviations, and a thermal term needs the next temperature, which is not
known (taken as unchanged).  A level step is in the measured deviations once a cycle
after it was measured (nothing more to add).  A process effect needs the next cycle's
value of its channel: when the caller knows it (a planned spindle speed, the next
stick-out) the change from the measured cycle is forecast, β · Δx · C[i]; otherwise the
channel is taken as unchanged.  The shift is added to the measured deviations before
the correction is optimised.

A relation is in the measured deviations too, but it also changes what a correction
does: :func:`relation_composite` gives the matrix the correction is mapped through.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.fit import RELATION_T
from setupfix.diagnose.terms import EffectSpec, Layout, common_tool_row, register_row
from setupfix.model.effects import EffectsSection, ModelEffect

__all__ = ["spec_of", "forecast_shift", "relation_composite"]

Array = npt.NDArray[np.float64]


def spec_of(effect: ModelEffect) -> EffectSpec:
    """The engine's term of a model-file effect."""
    return EffectSpec(
        effect.kind,
        register=effect.register,
        dimension=effect.dimension,
        axis=effect.axis,
        along=effect.along,
        group=effect.group,
        channel=effect.channel,
        shape=effect.shape,
        tau=effect.tau or 0.0,
        reference=effect.reference,
        at=effect.at or 0.0,
        cycle=effect.cycle,
    )


def forecast_shift(
    section: EffectsSection,
    layout: Layout,
    *,
    time: float | None = None,
    ahead: float | None = None,
    process_change: Mapping[str, float] | None = None,
) -> Array:
    """Change of every dimension expected from the measured cycle to the next one.

    Parameters
    ----------
    section : EffectsSection
    layout : Layout
    time : float, optional [h]
        When the measured cycle was cut, hours since ``section.origin`` (default
        ``section.last_hours``, else 0); matters for a saturating drift only.
    ahead : float, optional [h]
        Interval to the next cycle (default ``section.cycle_hours``, else 0).
    process_change : mapping of str to float, optional
        Change of each process channel from the measured cycle to the next one (a
        channel not given is taken as unchanged).

    Returns
    -------
    ndarray of shape (n_dimensions,) [model unit]
        drift (linear): β · Δt · c_T; drift (saturating): β · (e^{−t/τ} − e^{−(t+Δt)/τ}) · c_T;
        wear: β · C[tool] (one more cycle); process: β · Δx · C[register] (or c_T);
        other kinds (level included): 0.
    """
    t = time if time is not None else (section.last_hours or 0.0)
    dt = ahead if ahead is not None else (section.cycle_hours or 0.0)
    out = np.zeros(layout.n_dimensions)
    for e in section.effects:
        if e.kind == "drift":
            tau = e.tau if e.shape == "saturating" else None
            step = np.exp(-t / tau) - np.exp(-(t + dt) / tau) if tau else dt
            out += e.estimate * step * common_tool_row(layout)
        elif e.kind == "wear" and e.register in layout.register_ids:
            out += e.estimate * layout.composite[layout.register_ids.index(e.register)]
        elif (
            e.kind == "process"
            and process_change
            and e.channel in process_change
            and (e.register is None or e.register in layout.register_ids)
        ):
            out += e.estimate * float(process_change[str(e.channel)]) * register_row(layout, e.register)
    return out


def relation_composite(section: EffectsSection, layout: Layout) -> Array:
    """The composite matrix with the section's relations added, C + Σ δ e_i e_qᵀ (eqs. 3–4).

    A relation changes the matrix only when its register is named (``registers`` empty
    or that register alone: a weight shared by registers that moved together would be a
    guess) and its weight is known to better than a third of itself (|δ| > 3 s.e.; a
    relation written without a standard error is taken as given).

    Returns
    -------
    ndarray of shape (n_registers, n_dimensions)
    """
    C = layout.composite.copy()
    for e in section.effects:
        if e.kind != "relation" or e.register not in layout.register_ids or e.dimension not in layout.dimension_ids:
            continue
        if set(e.registers) - {e.register}:
            continue
        if e.stderr is not None and abs(e.estimate) <= RELATION_T * e.stderr:
            continue
        C[layout.register_ids.index(str(e.register)), layout.dimension_ids.index(str(e.dimension))] += e.estimate
    return C
