"""The series' covariates from the shop's logs, as arrays: what each cycle was cut with.

The corrections in effect at each cycle (:func:`applied_at`: every log row at or before
its time), the parts cut by each tool since its last change (:func:`parts_since_change`),
the temperature sample at or just before each cycle (:func:`join_temperatures`) and the
typical interval between cycles (:func:`typical_step`).  Used by the use case that loads a
series (:mod:`setupfix.inputs.series_assembly`), the shop simulator and the walk forward.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["applied_at", "parts_since_change", "join_temperatures", "typical_step"]

Array = npt.NDArray[np.float64]


def typical_step(time: Array) -> float:
    """Typical interval between cycles [h]: the median gap within shifts (gaps ≤ 1 h), else of all gaps."""
    gaps = np.diff(time)
    short = gaps[gaps <= 1.0]
    if short.size:
        return float(np.median(short))
    return float(np.median(gaps)) if gaps.size else 0.0


def applied_at(
    times: Array, log_times: Array, log_register: npt.NDArray[np.intp], log_delta: Array, n_registers: int
) -> Array:
    """Register changes in effect at each time: every log row with timestamp ≤ t.

    Parameters
    ----------
    times : ndarray of shape (n_cycles,) [h]
    log_times : ndarray of shape (n_rows,) [h]
    log_register : ndarray of int, shape (n_rows,)
        Row of the register in the composite matrix.
    log_delta : ndarray of shape (n_rows,) [model unit]
    n_registers : int

    Returns
    -------
    ndarray of shape (n_cycles, n_registers) [model unit]
    """
    out = np.zeros((len(times), n_registers))
    if len(log_times) == 0:
        return out
    order = np.argsort(log_times, kind="stable")
    steps = np.zeros((len(order), n_registers))
    steps[np.arange(len(order)), log_register[order]] = log_delta[order]
    cum = np.vstack([np.zeros((1, n_registers)), np.cumsum(steps, axis=0)])
    idx = np.searchsorted(log_times[order], times, side="right")
    out[:] = cum[idx]
    return out


def parts_since_change(times: Array, change_times: list[Array]) -> Array:
    """Cycles of the series cut by each tool since its last change before each cycle.

    Parameters
    ----------
    times : ndarray of shape (n_cycles,) [h]
    change_times : list of ndarray
        Per tool, the times of its changes.

    Returns
    -------
    ndarray of shape (n_cycles, n_tools)
        For cycle k, the number of earlier cycles machined after the tool's last
        change at or before t_k.
    """
    order = np.argsort(times, kind="stable")
    sorted_t = times[order]
    out = np.zeros((len(times), len(change_times)))
    for j, changes in enumerate(change_times):
        ch = np.sort(np.asarray(changes, dtype=float))
        last = np.full(len(times), -np.inf)
        if ch.size:
            pos = np.searchsorted(ch, times, side="right") - 1
            last = np.where(pos >= 0, ch[np.maximum(pos, 0)], -np.inf)
        # cycles strictly before t_k and at or after the last change
        before = np.searchsorted(sorted_t, times, side="left")
        after_change = np.searchsorted(sorted_t, last, side="left")
        out[:, j] = before - after_change
    return out


def join_temperatures(times: Array, sample_times: Array, samples: Array) -> Array:
    """Temperature sample at or just before each time (the first sample before the log starts).

    Parameters
    ----------
    times : ndarray of shape (n_cycles,) [h]
    sample_times : ndarray of shape (n_samples,) [h], sorted
    samples : ndarray of shape (n_samples, n_channels) [°C]

    Returns
    -------
    ndarray of shape (n_cycles, n_channels)
    """
    idx = np.searchsorted(sample_times, times, side="right") - 1
    out: Array = samples[np.clip(idx, 0, len(sample_times) - 1)]
    return out
