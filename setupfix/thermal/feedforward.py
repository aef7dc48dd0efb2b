"""Thermal drift fed forward into a setup correction: pure functions, arrays in, arrays out.

Between two CMM reports the last correction already absorbed the thermal state of the
machine at the time the measured parts were cut.  What a correction made now must
add is therefore not the predicted drift itself (its absolute value counts the
absorbed part again) but its **change since the measured parts were cut**::

    ΔE = Ê(t_at) − Ê(t_measured)                                   (change since measured)

with each time joined to the temperature sample at or just before it
(``spec/measurements.md``, "Temperature log").  The registers the drift moves (the
thermal model says which; every tool-length register for spindle growth) get
``−ΔE`` converted to the process model's unit and rounded to its register grid,
unless ``|ΔE|`` is below the dead band::

    x_r = −round(f·ΔE / q)·q   for r in moved registers, if |f·ΔE| ≥ dead band, else 0

(``f`` the unit factor, ``q`` the register resolution).  Used by ``setupfix correct
--thermal`` (:mod:`setupfix.usecases.thermal_feedforward`), the closed-loop diagnosis (its
thermal candidate) and the operator TUI.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["sample_at_or_before", "drift_change", "feed_forward"]

Array = npt.NDArray[np.float64]


def sample_at_or_before(times: npt.ArrayLike, when: npt.ArrayLike) -> npt.NDArray[np.intp]:
    """Index of the last sample at or before each time.

    Parameters
    ----------
    times : array_like, shape (n,)
        Sample times, strictly increasing (s, or any monotone scale).
    when : array_like, shape (m,) or scalar
        Times to join (same scale).

    Returns
    -------
    ndarray of int, shape of ``when``
        ``-1`` where a time is before the first sample.
    """
    t = np.asarray(times, dtype=float)
    return np.searchsorted(t, np.asarray(when, dtype=float), side="right") - 1


def drift_change(
    drift: npt.ArrayLike, times: npt.ArrayLike, measured_at: npt.ArrayLike, at: float | None = None
) -> Array:
    """Predicted thermal change ΔE since the measured parts were cut (module docstring).

    Parameters
    ----------
    drift : array_like, shape (n,)
        Predicted thermal error at each sample (any reference: it cancels), target unit.
    times : array_like, shape (n,)
        Sample times, strictly increasing.
    measured_at : array_like, shape (m,) or scalar
        Times the measured parts were cut.
    at : float, optional
        Time of the correction (default: the last sample).

    Returns
    -------
    ndarray, shape of ``measured_at``
        ``Ê(at) − Ê(measured_at)``, target unit.

    Raises
    ------
    ValueError
        A time before the first sample (no temperature is known there) or ``at``
        before a measured time.
    """
    e = np.asarray(drift, dtype=float)
    t = np.asarray(times, dtype=float)
    i_meas = sample_at_or_before(t, measured_at)
    i_at = e.size - 1 if at is None else int(sample_at_or_before(t, at))
    if np.any(i_meas < 0) or i_at < 0:
        raise ValueError("a time lies before the first temperature sample")
    if np.any(np.asarray(measured_at, dtype=float) > t[-1]):
        raise ValueError("the measured parts were cut after the last temperature sample")
    if at is not None and np.any(np.asarray(measured_at, dtype=float) > at):
        raise ValueError("the measured parts were cut after the time of the correction")
    return np.asarray(e[i_at] - e[i_meas], dtype=float)


def feed_forward(
    delta: float, moves: npt.ArrayLike, *, factor: float = 1.0, resolution: float = 0.0, dead_band: float = 0.0
) -> Array:
    """Register corrections that cancel a thermal change ΔE (module docstring).

    Parameters
    ----------
    delta : float
        ΔE from :func:`drift_change`, the thermal model's unit.
    moves : array_like of bool, shape (R,)
        Which registers the drift moves.
    factor : float
        Length of one thermal-model unit in the process model's unit (1e-3 for µm → mm).
    resolution : float
        Register grid step q (0: no rounding), process model unit.
    dead_band : float
        Below this |f·ΔE| nothing is fed forward, process model unit.

    Returns
    -------
    ndarray, shape (R,)
        ``−f·ΔE`` (rounded to the grid) on the moved registers, 0 elsewhere; all 0
        inside the dead band.

    Raises
    ------
    ValueError
        A non-finite ΔE.
    """
    mask = np.asarray(moves, dtype=bool)
    shift = -float(delta) * float(factor)
    if not np.isfinite(shift):
        raise ValueError("the thermal change is not finite")
    if abs(shift) < dead_band:
        return np.zeros(mask.shape)
    if resolution > 0:
        shift = float(np.round(shift / resolution)) * resolution
    return np.where(mask, shift, 0.0)
