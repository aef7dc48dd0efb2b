"""Lumped-mass machine simulator: temperature logs with a known thermal error.

The machine has heat sources (spindle motor, spindle bearing, …), each a lumped mass
obeying the modified lumped-mass law of Wang et al. (2017) eq. (4) — implicit Euler,
heat proportional to speed — so the fusion model can, in principle, recover it
exactly.  The thermal error does *not* follow the sensors directly: it follows
structure temperatures that lag the heat-source temperatures by a first-order delay
(``structure_tau_s``), which neither MRA nor the fusion model represents.  That
mismatch, sensor noise and process noise keep the comparison honest.

A log is a :class:`pandas.DataFrame` in the temperature-log format of
``spec/measurements.md``: ``timestamp`` (ISO 8601), one column per sensor (°C),
``ambient`` (°C), ``spindle_speed`` (rpm) and the measured error ``error_z`` (mm).
Sensor errors of the robustness study (eq. (18) sinusoidal, eq. (19) constant) and
sensor failures are applied with :func:`add_sensor_error` and :func:`fail_sensor`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from setupfix.search import generator

__all__ = [
    "HeatSource",
    "MachineConfig",
    "SimulatedRun",
    "speed_profile",
    "simulate",
    "sinusoidal_error",
    "constant_error",
    "add_sensor_error",
    "fail_sensor",
]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class HeatSource:
    """One heated lumped mass with a sensor on it.

    Attributes
    ----------
    name : str
        Sensor column name.
    tau_s : float
        Thermal time constant m c / (h A) in seconds.
    rise_per_krpm : float
        Steady temperature rise above ambient per 1000 rpm (K).
    error_mm_per_k : float
        Thermal error per kelvin of the (lagged) structure temperature it heats.
    speed_exponent : float
        Heat grows as ``(n / 1000 rpm) ** speed_exponent``; 1 is the paper's eq. (3),
        other values are a heat law the lumped-mass model does not know.
    """

    name: str
    tau_s: float
    rise_per_krpm: float
    error_mm_per_k: float
    speed_exponent: float = 1.0

    def coefficients(self, dt: float) -> tuple[float, float]:
        """``v1`` and ``v2`` of eq. (4) (M = 1, speed in 1000 rpm) for sampling interval ``dt``."""
        v1 = dt / self.tau_s
        return v1, self.rise_per_krpm * v1


@dataclass(frozen=True)
class MachineConfig:
    """A simulated machine; defaults give a ram-type spindle of order 0.1 mm drift."""

    dt_s: float = 10.0
    sources: tuple[HeatSource, ...] = (
        HeatSource("spindle_motor", tau_s=1500.0, rise_per_krpm=4.0, error_mm_per_k=0.004),
        HeatSource("bearing", tau_s=2400.0, rise_per_krpm=3.0, error_mm_per_k=0.006, speed_exponent=1.3),
    )
    ambient_c: float = 20.0
    ambient_amplitude_c: float = 0.1
    ambient_period_s: float = 86400.0
    sensor_noise_c: float = 0.05
    process_noise_c: float = 0.02
    structure_tau_s: float = 600.0
    error_noise_mm: float = 0.0005
    start: str = "2026-01-05T06:00:00"


@dataclass(frozen=True)
class SimulatedRun:
    """A simulated log and the truth behind it."""

    frame: pd.DataFrame
    true_temperatures: Array  #: (n, S) noise-free heat-source temperatures, °C
    true_error: Array  #: (n,) thermal error without measurement noise, mm
    config: MachineConfig = field(repr=False, default_factory=MachineConfig)


def speed_profile(
    kind: str, n: int, *, dt_s: float = 10.0, level: float = 1300.0, rng: np.random.Generator | None = None
) -> Array:
    """Spindle speed per sample (rpm).

    ``"constant"`` runs at ``level`` (Wang 2017, Case 1 at 1300 rpm); ``"variable"``
    holds random levels 0…3000 rpm for 15–45 min each (Case 2); ``"warmup"`` runs at
    ``level`` for the first two thirds and stops (heating then cooling).
    """
    rng = generator(rng)
    if kind == "constant":
        return np.full(n, float(level))
    if kind == "warmup":
        out = np.zeros(n)
        out[: 2 * n // 3] = level
        return out
    if kind == "variable":
        out = np.empty(n)
        i = 0
        while i < n:
            hold = int(rng.uniform(900.0, 2700.0) / dt_s)
            out[i : i + hold] = rng.choice([0.0, 500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0])
            i += max(hold, 1)
        return out
    raise ValueError(f"unknown speed profile {kind!r}")


def simulate(
    speed: npt.ArrayLike, config: MachineConfig | None = None, *, seed: int | None = None, initial_rise_c: float = 0.0
) -> SimulatedRun:
    """Simulate one run of the machine for a speed profile.

    Parameters
    ----------
    speed : array_like, shape (n,)
        Spindle speed per sample (rpm).
    config : MachineConfig
    seed : int
        Seed of every noise draw.
    initial_rise_c : float
        Heat-source temperature above ambient at the start (0: cold start).

    Returns
    -------
    SimulatedRun
    """
    cfg = config or MachineConfig()
    rng = generator(seed)
    n = np.asarray(speed, dtype=float)
    steps = n.size
    t = np.arange(steps) * cfg.dt_s
    ambient = cfg.ambient_c + cfg.ambient_amplitude_c * np.sin(2 * np.pi * t / cfg.ambient_period_s)
    S = len(cfg.sources)
    T = np.empty((steps, S))
    structure = np.empty((steps, S))
    a_s = 1.0 / (1.0 + cfg.dt_s / cfg.structure_tau_s)
    for i, src in enumerate(cfg.sources):
        v1, v2 = src.coefficients(cfg.dt_s)
        T[0, i] = ambient[0] + initial_rise_c
        structure[0, i] = T[0, i]
        w = rng.normal(0.0, cfg.process_noise_c, steps)
        for j in range(1, steps):  # eq. (4) with M = 1
            heat = v2 * (n[j] / 1000.0) ** src.speed_exponent
            T[j, i] = (T[j - 1, i] + v1 * ambient[j] + heat) / (1.0 + v1) + w[j]
            structure[j, i] = a_s * structure[j - 1, i] + (1.0 - a_s) * T[j, i]
    coeff = np.array([src.error_mm_per_k for src in cfg.sources])
    true_error = (structure - structure[0]) @ coeff
    measured = T + rng.normal(0.0, cfg.sensor_noise_c, T.shape)
    error = true_error + rng.normal(0.0, cfg.error_noise_mm, steps)
    stamps = pd.Timestamp(cfg.start) + pd.to_timedelta(t, unit="s")
    frame = pd.DataFrame({"timestamp": stamps.strftime("%Y-%m-%dT%H:%M:%S")})
    for i, src in enumerate(cfg.sources):
        frame[src.name] = np.round(measured[:, i], 3)
    frame["ambient"] = np.round(ambient + rng.normal(0.0, cfg.sensor_noise_c / 5, steps), 3)
    frame["spindle_speed"] = n
    frame["error_z"] = np.round(error, 5)
    return SimulatedRun(frame, T, true_error, cfg)


def sinusoidal_error(t_s: npt.ArrayLike) -> Array:
    """Sinusoidal sensor error of Wang (2017) eq. (18): 2 sin(t / 350) °C, t in seconds."""
    return 2.0 * np.sin(np.asarray(t_s, dtype=float) / 350.0)


def constant_error(t_s: npt.ArrayLike) -> Array:
    """Constant sensor error of Wang (2017) eq. (19): −2 °C."""
    return np.full(np.shape(t_s), -2.0)


def _seconds(frame: pd.DataFrame) -> Array:
    stamps = pd.to_datetime(frame["timestamp"])
    return np.asarray((stamps - stamps.iloc[0]).dt.total_seconds(), dtype=np.float64)


def add_sensor_error(frame: pd.DataFrame, column: str, error: Callable[[Array], Array]) -> pd.DataFrame:
    """Copy of ``frame`` with ``error(t)`` (°C, t in s from the start) added to one sensor."""
    out = frame.copy()
    out[column] = out[column] + error(_seconds(frame))
    return out


def fail_sensor(frame: pd.DataFrame, column: str, at: int, value: float = float("nan")) -> pd.DataFrame:
    """Copy of ``frame`` whose sensor ``column`` reads ``value`` from sample ``at`` on.

    NaN is a missing reading; a large value (e.g. −200 °C, an open PT100) is a jump.
    """
    out = frame.copy()
    out.loc[out.index[at:], column] = value
    return out
