"""Rules as a share of the tolerance: dead band in %, gain, mean of the last n parts, parts between moves.

The conventions of the controls and gauging systems shops already run (documented side by
side in ``docs/explanation/safety.md``): Siemens measuring cycles' ``_TZL`` (a zero-offset
range below which nothing is corrected) and ``_K`` (the mean over k parts), EZ-Comp's
limits and running average.  Here, for one cycle:

* **dead band as a share** — with ``[safety] dead_band = "N %"`` the correction is held
  unless some dimension's predicted change exceeds N % of its tolerance width
  (:func:`share_bands`, :func:`within_share_band`); per register, ``"N %"`` becomes an absolute
  band: N % of the narrowest width, over the weight, of the dimensions it moves
  (:func:`register_share_bands`);
* **gain** — k × the optimum, rounded towards zero on the grid
  (:func:`setupfix.correction.safety.apply_gain`);
* **mean of n** — the decision is taken on the mean of this part and the n − 1 parts
  before it, each moved by the corrections applied since (:func:`mean_of_parts`);
* **parts between moves** — a register moves only when at least ``min_parts`` parts were
  measured since its last change, this one included (:func:`parts_since_change`); the
  others are held at 0 in the solve (:func:`with_rules`).

:func:`apply_rules` runs the after-solve rules on any optimum in the order
:func:`setupfix.correction.recommend.recommend` applies them (``replay`` calls it).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.correction.pose import PosedProblem
from setupfix.correction.safety import RuleEffect, apply_gain, in_dead_band, short_list
from setupfix.model import ProcessModel
from setupfix.model.safety import Rules
from setupfix.optimize import CorrectionProblem

__all__ = [
    "Applied",
    "share_bands",
    "within_share_band",
    "register_share_bands",
    "parts_since_change",
    "mean_of_parts",
    "apply_rules",
    "dimension_changes",
    "with_rules",
]

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def share_bands(lower: Array, upper: Array, share: float | None, zone: npt.ArrayLike | None = None) -> Array:
    """Each dimension's dead band: ``share`` × its tolerance width [model unit].

    The width is upper − lower (a circular position zone, limits 0 and R: its diameter 2R);
    0 where the width is not finite (a one-sided tolerance: the share cannot hold it) or
    ``share`` is None.

    lower, upper : ndarray of shape (n,) [model unit] → ndarray of shape (n,) [model unit]
    """
    lo = np.asarray(lower, dtype=np.float64)
    up = np.asarray(upper, dtype=np.float64)
    if share is None:
        return np.zeros(lo.shape)
    width = up - lo
    if zone is not None:
        width = np.where(np.asarray(zone, dtype=bool), 2 * up, width)
    with np.errstate(invalid="ignore"):
        band = share * width
    return np.where(np.isfinite(band), band, 0.0)


def within_share_band(change: Array, band: Array) -> bool:
    """True when every dimension's predicted change is within its band: |Δd_q| ≤ band_q.

    change, band : ndarray of shape (n_dimensions,) [model unit]; NaN changes (not measured) count as 0.
    """
    c = np.nan_to_num(np.abs(np.asarray(change, dtype=np.float64)), nan=0.0)
    return bool(np.all(c <= np.asarray(band) + 1e-12))


def register_share_bands(composite: Array, width: Array, share: Array) -> Array:
    """Per-register dead bands [model unit] from a share of the tolerance (``[wks.ID] dead_band = "N %"``).

    band_j = share_j · min_q (width_q / |C_jq|) over the dimensions q register j moves (C_jq ≠ 0,
    finite width): a change within it moves no dimension by more than the share of its width.
    NaN share (none given) → NaN; no such dimension → 0.

    composite : (n_registers, n_dimensions); width : (n_dimensions,) [unit]; share : (n_registers,)
    → ndarray of shape (n_registers,) [unit]
    """
    c = np.abs(np.asarray(composite, dtype=np.float64))
    w = np.asarray(width, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.where((c > 0) & np.isfinite(w)[None, :], w[None, :] / c, np.inf)
    narrow = reach.min(axis=1) if reach.size else np.full(c.shape[0], np.inf)
    narrow = np.where(np.isfinite(narrow), narrow, 0.0)
    return np.asarray(share, dtype=np.float64) * narrow


def parts_since_change(
    now: np.datetime64,
    times: npt.NDArray[np.datetime64],
    log_times: npt.NDArray[np.datetime64],
    log_register: IntArray,
    n_registers: int,
) -> IntArray:
    """Parts measured since each register's last logged change, this part (at ``now``) included.

    A part counts when it was machined after the register's last change (logged at or before
    ``now``) and before ``now``; a register never changed counts every earlier part.

    times : (n_parts,) datetime64; log_times, log_register : (n_log,) (register −1: not in the model)
    → int ndarray of shape (n_registers,)
    """
    earlier = np.sort(np.asarray(times, dtype="datetime64[ns]")[np.asarray(times) < now])
    last = np.full(n_registers, np.datetime64("NaT", "ns"))
    logged = (np.asarray(log_register) >= 0) & (np.asarray(log_times) <= now)
    for j, t in zip(
        np.asarray(log_register)[logged], np.asarray(log_times, dtype="datetime64[ns]")[logged], strict=True
    ):
        if np.isnat(last[j]) or t > last[j]:
            last[j] = t
    counts = np.array(
        [earlier.size if np.isnat(t) else earlier.size - np.searchsorted(earlier, t, side="right") for t in last],
        dtype=np.int64,
    )
    return counts + 1


def mean_of_parts(deviation: Array, earlier: Array, n: int) -> tuple[Array, int]:
    """The mean of this part's deviations and the last n − 1 earlier parts' (Siemens ``_K``, EZ-Comp's average).

    Each dimension averages the values it has (NaN: not measured); a dimension this part does
    not measure stays NaN (a mean never measures what was not measured).

    Parameters
    ----------
    deviation : ndarray of shape (n_dimensions,) [unit]
    earlier : ndarray of shape (n_parts, n_dimensions) [unit]
        Earlier parts, oldest first, moved to the machine as it is now
        (:func:`setupfix.correction.ewma.shifted_history`).
    n : int >= 1

    Returns
    -------
    mean : ndarray of shape (n_dimensions,) [unit]
    used : int
        Earlier parts that entered the mean.
    """
    rows = np.asarray(earlier, dtype=np.float64)[max(0, len(earlier) - (n - 1)) :] if n > 1 else np.zeros((0, 0))
    if rows.size == 0:
        return np.asarray(deviation, dtype=np.float64).copy(), 0
    stack = np.vstack([rows, np.asarray(deviation, dtype=np.float64)[None, :]])
    with np.errstate(invalid="ignore"):
        mean = np.nansum(stack, axis=0) / np.sum(~np.isnan(stack), axis=0)
    return np.where(np.isnan(deviation), np.nan, mean), int(rows.shape[0])


@dataclass(frozen=True)
class Applied:
    """An optimum after the rules: the change to apply and the rule that held it ("" when none did)."""

    x: Array
    held_by: str = ""
    gained: bool = False


def apply_rules(
    x: Array,
    composite: Array,
    lower: Array,
    upper: Array,
    resolution: float,
    rules: Rules,
    parts_since: IntArray | None = None,
) -> Applied:
    """The after-solve rules on an optimum, in :func:`setupfix.correction.recommend.recommend`'s order.

    Registers with fewer than ``rules.min_parts`` parts since their last change (``parts_since``)
    are held at 0 (``correct`` holds them in the solve itself) → gain → dead band (every
    |x_j| ≤ ``rules.dead_band``, default 2 × resolution) → dead band as a share (every
    dimension's |Δd_q| ≤ share × width).

    Parameters
    ----------
    x : ndarray of shape (n_registers,) [unit]
    composite : ndarray of shape (n_registers, n_dimensions)
        C (eqs. 3–4): Δd = x · C.
    lower, upper : ndarray of shape (n_dimensions,) [unit]
    resolution : float [unit]
    rules : Rules
    parts_since : int ndarray of shape (n_registers,), optional
        :func:`parts_since_change`; None: the rule is not applied.
    """
    x = np.asarray(x, dtype=np.float64)
    if parts_since is not None and rules.min_parts > 1:
        blocked = np.asarray(parts_since) < rules.min_parts
        x = np.where(blocked, 0.0, x)
        if blocked.any() and not np.any(x):
            return Applied(x + 0.0, "min_parts")
    xg = apply_gain(x, np.full(x.shape, rules.gain), resolution)
    gained = bool(np.any(xg != x))
    if not np.any(xg):
        return Applied(xg + 0.0, "", gained)
    band = rules.dead_band if rules.dead_band is not None else 2 * resolution
    if in_dead_band(xg, np.full(x.shape, band)):
        return Applied(np.zeros_like(xg), "dead_band", gained)
    if rules.dead_band_share is not None:
        change = xg @ np.asarray(composite, dtype=np.float64)
        if within_share_band(change, share_bands(lower, upper, rules.dead_band_share)):
            return Applied(np.zeros_like(xg), "dead_band_share", gained)
    return Applied(xg + 0.0, "", gained)


def dimension_changes(problem: CorrectionProblem, x: Array) -> tuple[tuple[str, ...], Array, Array, Array]:
    """Each model dimension's predicted change under x (a zone: its radial distance's), with its limits.

    Returns ids, change, lower, upper (ndarrays of shape (n,) [unit]) in
    :meth:`CorrectionProblem.dimension_table` order.
    """
    ids, dev, pred, lower, upper, _ = problem.dimension_table(x)
    return ids, pred - dev, lower, upper


def with_rules(posed: PosedProblem, model: ProcessModel, parts_since: IntArray | None = None) -> PosedProblem:
    """The posed problem with the rules of this module in its policy, blocked registers held at 0.

    * ``policy.dimension_band`` ← ``[safety] dead_band = "N %"`` over the model dimensions of
      the problem (:func:`share_bands`), None when not given;
    * ``policy.dead_band`` of a register with ``dead_band = "N %"`` ← :func:`register_share_bands`;
    * registers with ``parts_since`` below their ``min_parts`` (register's, else ``[safety]``)
      held at 0 in the guarded problem, with the rule ``min_parts``.

    Unchanged (the same object) when no such rule is set.
    """
    s = model.safety
    regs = {r.id: r for r in model.registers}
    problem, policy = posed.problem, posed.policy
    reg_share = np.array(
        [
            np.nan if regs[r].policy.dead_band_share is None else regs[r].policy.dead_band_share
            for r in problem.register_ids
        ],
        dtype=np.float64,
    )
    min_parts = np.array(
        [regs[r].policy.min_parts or s.min_parts for r in problem.register_ids],
        dtype=np.int64,
    )
    changes: dict[str, Any] = {}
    if s.dead_band_share is not None:
        ids, _, lower, upper = dimension_changes(problem, np.zeros(problem.n_registers))
        dims = {d.id: d for d in model.dimensions}
        zone = np.array([dims[d].zone for d in ids], dtype=bool)
        changes["dimension_band"] = share_bands(lower, upper, s.dead_band_share, zone)
    if np.isfinite(reg_share).any():
        width = problem.upper - problem.lower
        bands = register_share_bands(problem.composite, width, np.nan_to_num(reg_share, nan=0.0))
        changes["dead_band"] = np.where(np.isfinite(reg_share), bands, policy.dead_band)
    effects = posed.effects
    guarded = posed.guarded
    if parts_since is not None and np.any(min_parts > 1):
        changes["min_parts"] = min_parts
        changes["parts_since"] = np.asarray(parts_since, dtype=np.int64)
        blocked = (np.asarray(parts_since) < min_parts) & (guarded.ub > guarded.lb)
        if blocked.any():
            held = tuple(r for r, b in zip(problem.register_ids, blocked, strict=True) if b)
            guarded = dataclasses.replace(
                guarded, lb=np.where(blocked, 0.0, guarded.lb), ub=np.where(blocked, 0.0, guarded.ub)
            )
            shown = short_list(regs[r].register for r in held)
            effects = (
                *effects,
                RuleEffect(
                    "min_parts",
                    f"{shown} held at 0: fewer parts measured since its last change than min_parts",
                    registers=held,
                ),
            )
    if not changes:
        return posed
    return dataclasses.replace(posed, policy=dataclasses.replace(policy, **changes), guarded=guarded, effects=effects)
