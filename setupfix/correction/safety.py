"""Safety rules between the optimum and the machine: pure functions, arrays in and out.

The rules follow what every probing and gauging system applies before an offset
reaches a controller (Renishaw Inspection Plus null band / feedback % / upper
tolerance; Siemens measuring cycles' zero-offset range, mean value and dimension
difference check; ISO 14253-1 for decisions under measurement uncertainty):

* **reject band** — a deviation beyond a tolerance limit by more than the band is a
  broken tool, a bad measurement or a wrong part: no correction at all;
* **guard band** — the optimiser works on the tolerance shrunk by g·U at each limit
  (ISO 14253-1 conformance zone), so its margin is a proven margin;
* **cumulative limit** — |applied since the last reset + change| stays within it;
* **per-step clamp** — the register limit of the model;
* **gain** — only this fraction of the optimum is applied (feedback %);
* **no harm** — a correction never moves a dimension measured in tolerance out of it;
* **dead band** — when every change is within it the verdict is *hold*;
* **EWMA** — deviations smoothed over consecutive reports (λ), reset on a tool change
  (:mod:`setupfix.correction.ewma`).

This module holds the rules' data (:class:`Policy`, :class:`RuleEffect`,
:class:`Recommendation`) and the vectorised rules themselves.
:func:`setupfix.correction.pose.pose_problem` applies the rules that shape the problem (EWMA,
guard band, cumulative limit, costs) and :func:`setupfix.correction.recommend.recommend` those after
the solve, returning a :class:`Recommendation` with its verdict and the list of rules
that changed it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.optimize import CorrectionProblem, OptimizeResult

__all__ = [
    "RuleEffect",
    "Policy",
    "Recommendation",
    "reject_mask",
    "guard_limits",
    "cumulative_bounds",
    "apply_gain",
    "harmed_mask",
    "no_harm_floor",
    "in_dead_band",
    "VERDICTS",
    "STOPPED",
    "short_list",
]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]

#: The three verdicts, in order of severity.
VERDICTS = ("apply", "hold", "reject")

#: Optimiser statuses of a solve stopped before its answer was proved (time limit, solver failure).
STOPPED = ("time_limit", "solver_error")

#: Names an alarm or a rule message lists before "… and N more" (the full list is in the rule's dimensions).
SHOWN = 3


def short_list(names: Iterable[str], shown: int = SHOWN) -> str:
    """The first ``shown`` names and how many more: ``"A, B, C, … and 741 more"`` (one line for any length)."""
    items = list(names)
    if len(items) <= shown + 1:
        return ", ".join(items)
    return ", ".join(items[:shown]) + f", … and {len(items) - shown} more"


@dataclass(frozen=True)
class RuleEffect:
    """One rule that changed the recommendation, with what it changed."""

    rule: str
    message: str
    registers: tuple[str, ...] = ()
    dimensions: tuple[str, ...] = ()

    def to_json(self) -> dict[str, object]:
        return {
            "rule": self.rule,
            "message": self.message,
            "registers": list(self.registers),
            "dimensions": list(self.dimensions),
        }


@dataclass(frozen=True)
class Policy:
    """The safety settings aligned with one :class:`CorrectionProblem`.

    Attributes
    ----------
    dead_band, gain, cumulative_limit, cumulative, cost : ndarray of shape (n_registers,)
        Dead band [unit], gain in (0, 1], bound on |cumulative + change| [unit] (inf: off),
        change applied since the last reset [unit], least-norm weight (> 0).
    reject_band, uncertainty : ndarray of shape (n_dimensions,)
        Reject band beyond each limit [unit]; expanded uncertainty U [unit].
    guard_band : float
        Fraction of U by which each limit is shrunk.
    dimension_band : ndarray of shape (n_model_dimensions,) or None
        Dead band as a share of each tolerance width [unit], in
        :meth:`CorrectionProblem.dimension_table` order (:mod:`setupfix.correction.rules`); None: off.
    min_parts, parts_since : int ndarrays of shape (n_registers,) or None
        Parts a register waits between changes, and parts measured since its last change.
    """

    dead_band: Array
    gain: Array
    cumulative_limit: Array
    cumulative: Array
    cost: Array
    reject_band: Array
    uncertainty: Array
    guard_band: float = 1.0
    dimension_band: Array | None = None
    min_parts: npt.NDArray[np.int64] | None = None
    parts_since: npt.NDArray[np.int64] | None = None

    @classmethod
    def neutral(cls, problem: CorrectionProblem) -> Policy:
        """No rule active: dead band 0, gain 1, no limits but the problem's, reject band ∞."""
        n, m = problem.n_registers, problem.deviation.shape[0]
        return cls(
            dead_band=np.zeros(n),
            gain=np.ones(n),
            cumulative_limit=np.full(n, np.inf),
            cumulative=np.zeros(n),
            cost=np.ones(n),
            reject_band=np.full(m, np.inf),
            uncertainty=np.zeros(m),
        )


@dataclass
class Recommendation:
    """What to do with one measured cycle.

    Attributes
    ----------
    verdict : {"apply", "hold", "reject"}
    x : ndarray of shape (n_registers,) [unit]
        The changes to apply (all zero unless the verdict is ``apply``).
    result : OptimizeResult
        The optimiser's result on the guarded problem (x = 0 when rejected).
    problem : CorrectionProblem
        The guarded problem actually solved (limits shrunk, bounds tightened).
    rules : tuple of RuleEffect
        Every rule that changed the recommendation.
    given_up : tuple of str
        Dimensions no setup correction brings into tolerance (need the NC program).
    at_limit : tuple of str
        Registers whose change sits at a bound (per-step clamp or cumulative limit).
    alarm : str
        One sentence for the operator when the verdict is ``reject`` (else empty).
    solved : bool
        False when the solve was stopped (status in :data:`STOPPED`: time limit, solver
        error) and nothing is recommended (verdict ``hold``): the hold then means "not
        solved within the time limit", never "no change needed"; the rule ``not_solved``
        says so.  A stopped solve that still yields a correction (checked better than none,
        e.g. the grid optimum proved but not the least norm) is ``apply`` with the rule
        ``stopped`` stating what is certified (``result.norm_ratio_max``).
    """

    verdict: str
    x: Array
    result: OptimizeResult
    problem: CorrectionProblem
    rules: tuple[RuleEffect, ...] = ()
    given_up: tuple[str, ...] = ()
    at_limit: tuple[str, ...] = ()
    alarm: str = ""
    solved: bool = True


def reject_mask(deviation: Array, lower: Array, upper: Array, band: Array) -> Mask:
    """Dimensions beyond a limit by more than the reject band.

    deviation, lower, upper, band : ndarray of shape (n_dimensions,) [unit]
    → bool ndarray of shape (n_dimensions,)
    """
    return (deviation < lower - band) | (deviation > upper + band)


def guard_limits(lower: Array, upper: Array, uncertainty: Array, fraction: float = 1.0) -> tuple[Array, Array]:
    """Tolerance limits shrunk by ``fraction · U`` at each end (ISO 14253-1 conformance zone).

    Where the zone would vanish (2gU ≥ upper − lower), both limits become the
    mid-tolerance, so the margin measures the distance to the centre (negative).

    Returns
    -------
    lower, upper : ndarrays of shape (n_dimensions,) [unit]
    """
    g = fraction * np.asarray(uncertainty, dtype=float)
    lo, up = lower + g, upper - g
    mid = (lower + upper) / 2
    crossed = lo > up
    return np.where(crossed, mid, lo), np.where(crossed, mid, up)


def cumulative_bounds(lb: Array, ub: Array, cumulative: Array, limit: Array, resolution: float) -> tuple[Array, Array]:
    """Step bounds that keep |cumulative + change| ≤ limit, snapped inwards on the grid.

    A register already beyond its cumulative limit may only move back: its bound on
    the far side becomes 0.  lb, ub, cumulative, limit : shape (n_registers,) [unit].
    """
    h = resolution
    lo = np.maximum(lb, np.ceil((-limit - cumulative) / h - 1e-9) * h)
    hi = np.minimum(ub, np.floor((limit - cumulative) / h + 1e-9) * h)
    lo = np.where(np.isfinite(limit), np.minimum(lo, 0.0), lb)
    hi = np.where(np.isfinite(limit), np.maximum(hi, 0.0), ub)
    # A register pushed beyond its bounds by both sides collapses to "no change".
    return np.where(lo > hi, 0.0, lo), np.where(lo > hi, 0.0, hi)


def apply_gain(x: Array, gain: Array, resolution: float) -> Array:
    """Feedback fraction of the changes, rounded towards zero onto the grid.

    Rounding towards zero keeps gain·x between 0 and x register by register, so a
    dimension inside its limits at x = 0 and at x stays inside (margins are concave).
    """
    steps = np.trunc(np.asarray(gain) * x / resolution + np.sign(x) * 1e-9)
    return steps * resolution + 0.0


def harmed_mask(deviation: Array, predicted: Array, lower: Array, upper: Array) -> Mask:
    """Dimensions measured in tolerance and predicted out of tolerance after a change."""
    inside_before = (deviation >= lower) & (deviation <= upper)
    inside_after = (predicted >= lower - 1e-12) & (predicted <= upper + 1e-12)
    return inside_before & ~inside_after


def in_dead_band(x: Array, dead_band: Array) -> bool:
    """True when every change is within its register's dead band (|x_j| ≤ band_j)."""
    return bool(np.all(np.abs(x) <= dead_band + 1e-12))


def no_harm_floor(deviation: Array, lower: Array, upper: Array, guarded_lower: Array, guarded_upper: Array) -> Array:
    """No-harm floor of the guarded problem: a dimension measured inside its real limits keeps
    a guarded margin ≥ −(the guard band's shrink), i.e. stays inside the real limits.

    deviation, lower, upper : ndarray of shape (n_dimensions,) [unit]
        The (estimated) deviations and the real limits.
    guarded_lower, guarded_upper : ndarray of shape (n_dimensions,) [unit]
        The limits shrunk by :func:`guard_limits`.

    Returns
    -------
    ndarray of shape (n_dimensions,) [unit]
        −shrink (≤ 0; the smaller shrink of the two sides) where measured inside, −inf elsewhere
        (:attr:`setupfix.optimize.CorrectionProblem.floor`).
    """
    with np.errstate(invalid="ignore"):
        low = np.where(np.isfinite(lower), guarded_lower - lower, np.inf)
        high = np.where(np.isfinite(upper), upper - guarded_upper, np.inf)
    shrink = np.minimum(low, high)
    shrink = np.where(np.isfinite(shrink), np.maximum(shrink, 0.0), 0.0)
    inside = (deviation >= lower) & (deviation <= upper)
    return np.where(inside, -shrink, -np.inf)
