"""Replay a rule set over a measured history, through the model (layer 3: arrays in, arrays out).

The stored history says what each part measured (d_t) and which register changes were in
effect when it was machined (A_t, the corrections log summed up to the part).  The model's
relation (Stryczek 2014, eqs. 3–4: a register change x moves the dimensions by x · C)
takes the corrections out and puts the rule's in:

    y_t = d_t + (S_t − A_t) · C

with S_t the changes the rule set would have made before part t.  After each part the
rule decides on the mean of the last ``mean_of`` parts moved to the machine as it is then
(:func:`setupfix.correction.rules.mean_of_parts`), the optimum being the least-squares
centring through the model on the register grid,

    x*_t = round(−(ȳ_t − target) · C⁺ / h) · h      (C⁺ the pseudo-inverse, h the grid step,
                                                    target the tolerance middle, unmeasured
                                                    dimensions left out),

and :func:`setupfix.correction.rules.apply_rules` (the rules' one implementation: minimum
parts since a register's change, gain, dead band, dead band as a share) turns it into the
change applied before part t + 1.  Where S_t = A_t the replayed part is the measured one
bit for bit (the difference is exactly zero).

The replay assumes the model: an error of C, or a process that changes with the corrections
themselves, is not in it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.correction.explain import targets
from setupfix.correction.rules import apply_rules, mean_of_parts
from setupfix.model.safety import Rules

__all__ = ["ReplayTrace", "replay_rules", "centring_step"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ReplayTrace:
    """What a rule set would have done over a history.

    Attributes
    ----------
    deviation : ndarray of shape (n_parts, n_dimensions) [unit]
        y_t, the parts as the rule set would have left them (NaN: not measured).
    applied : ndarray of shape (n_parts, n_registers) [unit]
        S_t, the rule's changes in effect when each part was machined.
    moves : ndarray of shape (n_parts, n_registers) [unit]
        The change decided after each part (0: none).
    held_by : tuple of str
        Per part, the rule that held the change ("" when none did or there was nothing to move).
    """

    deviation: Array
    applied: Array
    moves: Array
    held_by: tuple[str, ...]


def centring_step(
    mean: Array,
    composite: Array,
    lower: Array,
    upper: Array,
    resolution: float,
    inverses: dict[bytes, Array] | None = None,
) -> Array:
    """x* = round(−(ȳ − target) · C⁺ / h) · h over the measured dimensions (least-squares centring).

    mean : (n_dimensions,) [unit], NaN where unmeasured; composite : (n_registers, n_dimensions);
    lower, upper : (n_dimensions,) [unit]; resolution h [unit] → ndarray (n_registers,) [unit].
    ``inverses`` caches C⁺ per set of measured dimensions (the same pseudo-inverse, computed once).
    """
    seen = np.isfinite(mean)
    if not seen.any():
        return np.zeros(composite.shape[0])
    gap = mean[seen] - targets(lower, upper)[seen]
    key = seen.tobytes()
    cache: dict[bytes, Array] = {} if inverses is None else inverses
    if key not in cache:
        cache[key] = np.asarray(np.linalg.pinv(composite[:, seen]), dtype=np.float64)
    x = -(gap @ cache[key])
    out: Array = np.round(x / resolution) * resolution + 0.0
    return out


def replay_rules(
    measured: Array,
    actual: Array,
    composite: Array,
    lower: Array,
    upper: Array,
    resolution: float,
    rules: Rules,
) -> ReplayTrace:
    """Replay ``rules`` over a history in time order (see the module docstring).

    Parameters
    ----------
    measured : ndarray of shape (n_parts, n_dimensions) [unit]
        d_t, NaN where a part did not measure a dimension.
    actual : ndarray of shape (n_parts, n_registers) [unit]
        A_t, the logged changes in effect when each part was machined (summed from the first part's
        state: ``actual[0]`` is the baseline both replays start from).
    composite : ndarray of shape (n_registers, n_dimensions)
        C: a change x moves the dimensions by x · C.
    lower, upper : ndarray of shape (n_dimensions,) [unit]
    resolution : float [unit]
        The register grid step h.
    rules : Rules

    Returns
    -------
    ReplayTrace
    """
    d = np.asarray(measured, dtype=np.float64)
    a = np.asarray(actual, dtype=np.float64)
    c = np.asarray(composite, dtype=np.float64)
    n, r = d.shape[0], c.shape[0]
    state = a[0].copy() if n else np.zeros(r)
    out = np.empty_like(d)
    applied = np.empty((n, r))
    moves = np.zeros((n, r))
    held: list[str] = []
    base = d - a @ c  # the parts without any correction, for the mean of earlier parts
    since = np.ones(r, dtype=np.int64)  # parts since each register's last change, this one included
    inverses: dict[bytes, Array] = {}
    for t in range(n):
        applied[t] = state
        diff = state - a[t]
        out[t] = d[t] + diff @ c if np.any(diff) else d[t]
        earlier = base[max(0, t - rules.mean_of + 1) : t] + state @ c
        mean, _ = mean_of_parts(out[t], earlier, rules.mean_of)
        step = centring_step(mean, c, lower, upper, resolution, inverses)
        result = apply_rules(step, c, lower, upper, resolution, rules, since)
        moves[t] = result.x
        held.append(result.held_by)
        moved = result.x != 0
        state = state + result.x
        since = np.where(moved, 1, since + 1)
    return ReplayTrace(out, applied, moves, tuple(held))
