"""EWMA smoothing of deviations over consecutive reports (the safety rule *EWMA*).

Pure functions, arrays in and out: λ-weighted means of a dimension's deviations over the
reports in time order, each earlier report first shifted by the corrections applied
since it was machined (the part would have come out that much different), and reset
where a tool was changed since.  :func:`setupfix.correction.pose.pose_problem` uses the estimate
in place of the measured deviations (step 2 of its order); the history comes from the
store (:mod:`setupfix.inputs.smoothing`).  The same shifted history gives the last
measurement of a dimension a report lacks (:func:`last_measured`, the coverage
stand-in).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note

__all__ = ["ewma", "ewma_series", "Smoothed", "ewma_history", "shifted_history", "last_measured"]

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


def ewma(measured: Array, previous: Array | None, lam: float) -> Array:
    """Exponentially weighted mean of deviations over reports: λ·y + (1 − λ)·previous.

    ``previous`` is the smoothed deviation of the last report shifted by the changes
    applied since (None after a reset or for the first report: y itself).
    Shapes (n_dimensions,) [unit]; NaN in ``previous`` falls back to y.
    """
    if previous is None or lam >= 1.0:
        return np.asarray(measured, dtype=float).copy()
    prev = np.where(np.isfinite(previous), previous, measured)
    return lam * measured + (1.0 - lam) * prev


def ewma_series(history: Array, lam: float) -> Array:
    """EWMA over reports in time order, the last row the current report.

    history : ndarray of shape (n_reports, n_dimensions) [unit]
        Deviations of earlier reports, each already shifted by the corrections
        applied since it was machined; NaN where a dimension was not measured or was
        reset (a tool change since: its earlier values no longer apply).
    lam : float
        λ in (0, 1]; a_k = λ·y_k + (1 − λ)·a_{k−1}, starting from the first value.

    Returns
    -------
    ndarray of shape (n_dimensions,)
    """
    a = np.full(history.shape[1], np.nan)
    for row in np.asarray(history, dtype=float):
        seen = ~np.isnan(row)
        a = np.where(seen, np.where(np.isnan(a), row, lam * row + (1.0 - lam) * a), a)
    return a


@dataclass(frozen=True, eq=False)
class Smoothed:
    """The EWMA estimate of one cycle's deviations (step 2).

    Attributes
    ----------
    deviation : ndarray of shape (n_dimensions,) [unit]
        Model order, NaN where the cycle did not measure the dimension.
    used : int
        Earlier parts that entered the estimate (0: the estimate is the measurement).
    lam : float
        λ of the smoothing.
    notes : tuple of Note
        Why nothing was smoothed (no timestamp …).
    """

    deviation: Array
    used: int
    lam: float
    notes: tuple[Note, ...] = ()


def ewma_history(
    deviation: Array,
    now: np.datetime64 | None,
    times: npt.NDArray[np.datetime64],
    earlier: Array,
    log_times: npt.NDArray[np.datetime64],
    log_register: npt.NDArray[np.int64],
    log_delta: Array,
    log_reset: Mask,
    composite: Array,
    lam: float,
    *,
    limit: int = 50,
) -> Smoothed:
    """EWMA of a cycle's deviations over the earlier parts, each shifted to the machine as it is now.

    An earlier part's deviation y_k becomes y_k + Σ Δx·C over the corrections logged
    after it was machined and up to ``now`` (eqs. 3–4), NaN on the dimensions a tool
    changed since cuts (its wear restarted); then a_k = λ·y_k + (1 − λ)·a_{k−1}
    (:func:`setupfix.correction.safety.ewma_series`), the last row the current cycle.

    Parameters
    ----------
    deviation : ndarray of shape (n_dimensions,)
        The cycle as measured (NaN where not measured).
    now : datetime64 or None
        When the cycle was machined; None: nothing is smoothed.
    times, earlier : ndarrays of shapes (n_parts,), (n_parts, n_dimensions)
        Earlier parts (any order; only those before ``now`` count, the last ``limit``).
    log_times, log_register, log_delta, log_reset : ndarrays of shape (n_log,)
        Corrections log: time, register index (−1: not in the model), change, tool change.
    composite : ndarray of shape (n_registers, n_dimensions)
    lam : float in (0, 1]
    """
    if lam >= 1.0 or now is None:
        return Smoothed(deviation, 0, lam)
    rows = shifted_history(now, times, earlier, log_times, log_register, log_delta, log_reset, composite, limit)
    if rows.shape[0] == 0:
        return Smoothed(deviation, 0, lam)
    smoothed = ewma_series(np.vstack([rows, deviation]), lam)
    return Smoothed(np.where(np.isnan(deviation), np.nan, smoothed), int(rows.shape[0]), lam)


def shifted_history(
    now: np.datetime64,
    times: npt.NDArray[np.datetime64],
    earlier: Array,
    log_times: npt.NDArray[np.datetime64],
    log_register: npt.NDArray[np.int64],
    log_delta: Array,
    log_reset: Mask,
    composite: Array,
    limit: int = 50,
) -> Array:
    """The last ``limit`` parts machined before ``now``, oldest first, each moved to the machine as it is now.

    y_k + Σ Δx·C over the corrections logged after part k and up to ``now`` (eqs. 3–4);
    NaN where a tool changed since cuts the dimension (its wear restarted) or where the
    part did not measure it.  Arguments as :func:`ewma_history`.

    Returns
    -------
    ndarray of shape (n_before, n_dimensions) [unit]
    """
    before = np.flatnonzero(times < now)
    before = before[np.argsort(times[before], kind="stable")][-limit:] if before.size else before
    rows = []
    known = log_register >= 0
    for k in before:
        t = times[k]
        since = known & (log_times > t) & (log_times <= now)
        reset = np.zeros(composite.shape[1], dtype=bool)
        shift = np.zeros(composite.shape[0])
        for j, delta, tool_change in zip(log_register[since], log_delta[since], log_reset[since], strict=True):
            if tool_change:
                reset |= composite[j] != 0
            elif np.isfinite(delta):
                shift[j] += delta
        row = earlier[k] + shift @ composite
        row[reset] = np.nan
        rows.append(row)
    return np.vstack(rows) if rows else np.zeros((0, composite.shape[1]))


def last_measured(rows: Array) -> Array:
    """Each dimension's most recent value in ``rows`` (oldest first; NaN where none): the coverage stand-in.

    rows : ndarray of shape (n_parts, n_dimensions) → ndarray of shape (n_dimensions,)
    """
    out = np.full(rows.shape[1], np.nan)
    for row in rows:
        out = np.where(np.isnan(row), out, row)
    return out
