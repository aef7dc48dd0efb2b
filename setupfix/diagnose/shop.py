"""Closed-loop shop simulator: a series of fixture cycles with hidden effects.

A machining centre cuts one fixture cycle every ``cycle_minutes`` in shifts of
``shift_cycles`` cycles separated by pauses.  Each cycle is measured; every
``correct_every`` cycles an operator computes a correction from the last cycles
measured (least-squares centring through the declared composite matrix, with a gain,
on the register grid) and applies it ``dead_time`` minutes after the last of those
parts was machined — parts cut meanwhile still carry the old offsets.  Tools are
changed every ``tool_change_every`` cycles (in turn); a change restarts wear only.

The truth is the declared model of Stryczek (2014, eqs. 3–4) with a setup error
drawn by eq. 12 (w1 · (1 − 2r) per register), measurement noise N(0, σ²), and the
hidden effects, each built by :func:`setupfix.diagnose.terms.effect_field`, so the
diagnosis and the simulator share one definition of every kind.

A spindle temperature follows a first-order lag towards ambient + ``heat`` while
the machine runs and towards ambient during pauses; ambient swings daily.

With ``process`` > 0 the shop also records process channels per cycle, as a designed
run would set them: ``speed_rpm`` (6000, 9000 or 12000, changed every 3 cycles),
``stickout_mm`` (30 or 45, changed every 9 cycles) and ``feed`` (100–300 mm/min, every
cycle); a hidden ``process`` effect acts through one of them, a hidden ``level`` is a step
at a time (``EffectSpec.at``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import ParameterError
from setupfix.core.params import Constraint, Interval, ValidatedParams, validate_params
from setupfix.diagnose.covariates import parts_since_change
from setupfix.diagnose.terms import AXES, KINDS, EffectSpec, Layout, Series, effect_field
from setupfix.search import generator

__all__ = ["HiddenEffect", "ShopSimulator", "SimulatedSeries", "random_topology"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class HiddenEffect:
    """An effect the simulator adds and the declared model lacks.

    Parameters
    ----------
    spec : EffectSpec
        Kind and target.
    magnitude : float
        Its coefficient: drift [unit/h] (linear) or amplitude [unit] (saturating),
        thermal [unit/°C], wear [unit/cycle], scale and position [unit/unit],
        relation [weight change], group [unit], level [unit], process [unit per unit of
        the channel].
    """

    spec: EffectSpec
    magnitude: float


@dataclass(frozen=True)
class SimulatedSeries:
    """What the shop recorded, and the truth behind it.

    Attributes
    ----------
    series : Series
        Cycles as the diagnosis sees them (times in h from the first cycle).
    log_time, log_register, log_delta, log_event
        Corrections log rows: time [h], register index, change [model unit],
        ``correction`` or ``tool_change`` (delta 0).
    temp_time : ndarray (n_samples,) [h]
    temp : ndarray (n_samples, n_channels) [°C]
    setup_error : ndarray (n_registers,) [model unit]
    effects : tuple of HiddenEffect
    noise : float [model unit]
    """

    series: Series
    log_time: Array
    log_register: npt.NDArray[np.intp]
    log_delta: Array
    log_event: tuple[str, ...]
    temp_time: Array
    temp: Array
    setup_error: Array
    effects: tuple[HiddenEffect, ...]
    noise: float
    truth: dict[str, Any] = field(default_factory=dict)


class ShopSimulator(ValidatedParams):
    """Seeded closed-loop simulation of a shop running one process model.

    Parameters
    ----------
    n_cycles : int, default=40
    noise : float, default=0.002 [model unit]
        Standard deviation of the measurement (and remaining process) noise.
    setup_error : float, default=0.03 [model unit]
        w1 of eq. 12: initial setup errors are uniform in ±setup_error.
    cycle_minutes : float, default=20
    shift_cycles : int, default=24
        Cycles per shift; a pause of ``pause_hours`` follows each shift.
    pause_hours : float, default=8
    correct_every : int, default=5
        Cycles between corrections (0: never correct).
    dead_time : float, default=30 [min]
        From machining the last part a correction uses to applying it.
    gain : float, default=0.7
        Fraction of the estimated setup error corrected.
    tool_change_every : int, default=16
        Cycles between tool changes (0: never); tools are changed in turn.
    heat : float, default=6 [°C]
        Spindle temperature rise while running.
    sparse : int, default=0
        0: every register gets its share of a correction; n > 0: only the n largest
        changes are applied (an operator touching few registers: the histories of the
        registers then differ, so a wrong relation can be assigned to its register).
    decimals : int, default=4
        Deviations rounded as a CMM prints them.
    process : int, default=0
        Process channels recorded per cycle (0–3: ``speed_rpm``, ``stickout_mm``, ``feed``).
    part_noise : float, default=0 [model unit]
        Shared per-part variation: every tool register (every register when the model
        has no tools) is off by its own N(0, part_noise²) offset, drawn anew each cycle,
        so all dimensions a tool cuts move together on that part (the cells of a cycle
        are correlated; real parts vary as a whole).
    seed : int or None
        Seed of the simulation; None means :data:`setupfix.search.DEFAULT_SEED` (never entropy).
    """

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "n_cycles": [Interval(int, 1, 1_000_000)],
        "noise": [Interval(float, 0, None)],
        "setup_error": [Interval(float, 0, None)],
        "cycle_minutes": [Interval(float, 0, None, closed="neither")],
        "shift_cycles": [Interval(int, 1, None)],
        "pause_hours": [Interval(float, 0, None)],
        "correct_every": [Interval(int, 0, None)],
        "dead_time": [Interval(float, 0, None)],
        "gain": [Interval(float, 0, 1)],
        "tool_change_every": [Interval(int, 0, None)],
        "heat": [Interval(float, 0, None)],
        "sparse": [Interval(int, 0, None)],
        "decimals": [Interval(int, 0, 12)],
        "process": [Interval(int, 0, 3)],
        "part_noise": [Interval(float, 0, None)],
        "seed": [Interval(int, 0, None), None],
    }

    def __init__(
        self,
        *,
        n_cycles: int = 40,
        noise: float = 0.002,
        setup_error: float = 0.03,
        cycle_minutes: float = 20.0,
        shift_cycles: int = 24,
        pause_hours: float = 8.0,
        correct_every: int = 5,
        dead_time: float = 30.0,
        gain: float = 0.7,
        tool_change_every: int = 16,
        heat: float = 6.0,
        sparse: int = 0,
        decimals: int = 4,
        process: int = 0,
        part_noise: float = 0.0,
        seed: int | None = None,
    ) -> None:
        self.n_cycles = n_cycles
        self.noise = noise
        self.setup_error = setup_error
        self.cycle_minutes = cycle_minutes
        self.shift_cycles = shift_cycles
        self.pause_hours = pause_hours
        self.correct_every = correct_every
        self.dead_time = dead_time
        self.gain = gain
        self.tool_change_every = tool_change_every
        self.heat = heat
        self.sparse = sparse
        self.decimals = decimals
        self.process = process
        self.part_noise = part_noise
        self.seed = seed

    def validate_params(self) -> None:
        validate_params("simulate", self.get_params(), self._parameter_constraints)

    # -- timeline -------------------------------------------------------------------------
    def _times(self) -> Array:
        k = np.arange(self.n_cycles)
        shift, within = np.divmod(k, self.shift_cycles)
        shift_len = self.shift_cycles * self.cycle_minutes / 60.0
        out: Array = shift * (shift_len + self.pause_hours) + within * self.cycle_minutes / 60.0
        return out

    def _temperatures(self, times: Array, rng: np.random.Generator) -> tuple[Array, Array]:
        """Spindle and ambient temperatures every 10 min over the series."""
        step = 1.0 / 6.0
        end = times[-1] + 1.0
        t = np.arange(-1.0, end + step, step)
        shift_len = self.shift_cycles * self.cycle_minutes / 60.0
        period = shift_len + self.pause_hours
        running = np.mod(np.maximum(t, 0.0), period) < shift_len
        running &= t >= 0
        ambient = 20.0 + 1.5 * np.sin(2 * np.pi * (t - 8.0) / 24.0)
        tau = 1.2  # h, spindle thermal time constant
        a = np.exp(-step / tau)
        spindle = np.empty_like(t)
        spindle[0] = ambient[0]
        for i in range(1, len(t)):  # first-order lag, exact discretisation (ZOH)
            target = ambient[i - 1] + self.heat * running[i - 1]
            spindle[i] = a * spindle[i - 1] + (1 - a) * target
        noise = rng.normal(0.0, 0.05, size=(len(t), 2))
        temp = np.column_stack([spindle, ambient]) + noise
        return t, np.round(temp, 2)

    def _process(self, rng: np.random.Generator) -> tuple[Array, tuple[str, ...]]:
        """Process channels per cycle, shape (n_cycles, process), and their names."""
        k = np.arange(self.n_cycles)
        speed = rng.choice([6000.0, 9000.0, 12000.0], size=k[-1] // 3 + 1)[k // 3]
        stick = rng.choice([30.0, 45.0], size=k[-1] // 9 + 1)[k // 9]
        feed = np.round(rng.uniform(100.0, 300.0, size=self.n_cycles))
        cols = np.column_stack([speed, stick, feed])[:, : self.process]
        return cols, ("speed_rpm", "stickout_mm", "feed")[: self.process]

    # -- run ------------------------------------------------------------------------------
    def run(self, layout: Layout, effects: tuple[HiddenEffect, ...] | list[HiddenEffect] = ()) -> SimulatedSeries:
        """Simulate the shop; return the series, its logs and the truth.

        Raises
        ------
        ParameterError
            If an effect is of an unknown kind, names an unknown target, or needs
            feature positions the model does not have.
        """
        self.validate_params()
        rng = generator(self.seed)
        C = layout.composite
        n_r, n_d = C.shape
        effects = tuple(effects)
        for e in effects:
            if e.spec.kind not in KINDS:
                raise ParameterError(f"simulate: unknown effect kind {e.spec.kind!r} (known: {', '.join(KINDS)})")
            if e.spec.kind == "position" and (
                e.spec.axis not in AXES or np.isnan(layout.coord[:, AXES.index(str(e.spec.axis))]).all()
            ):
                raise ParameterError(
                    "simulate: a position effect needs feature positions in the model "
                    "([features.*] position = [x, y, z])"
                )
        times = self._times()
        effects = tuple(_at_cycle(e, times) for e in effects)
        for e in effects:
            if e.spec.kind == "level" and not times[0] < e.spec.at <= times[-1]:
                raise ParameterError(
                    f"simulate: a level step at {e.spec.at:g} h is not within the series "
                    f"({times[0]:g} … {times[-1]:g} h): it would change no cycle or all alike"
                )
        t_temp, temp = self._temperatures(times, rng)
        # tool changes: in turn, every tool_change_every cycles, 5 min before the cycle
        n_t = layout.tools.size
        changes: list[list[float]] = [[] for _ in range(n_t)]
        log: list[tuple[float, int, float, str]] = []
        if self.tool_change_every and n_t:
            for i, k in enumerate(range(self.tool_change_every, self.n_cycles, self.tool_change_every)):
                j = i % n_t
                at = float(times[k] - 5.0 / 60.0)
                changes[j].append(at)
                log.append((at, int(layout.tools[j]), 0.0, "tool_change"))
        parts = parts_since_change(times, [np.array(c) for c in changes])
        temp_at = temp[np.clip(np.searchsorted(t_temp, times, side="right") - 1, 0, len(t_temp) - 1)]
        channels: tuple[str, ...] = ("spindle", "ambient")
        names: tuple[str, ...] = ()
        if self.process:
            proc, names = self._process(generator(None if self.seed is None else self.seed + 7919))
            temp_at = np.column_stack([temp_at, proc])
            channels += names
        setup: Array = np.asarray(self.setup_error * (1.0 - 2.0 * rng.random(n_r)), dtype=float)  # eq. 12
        noise = rng.normal(0.0, self.noise, size=(self.n_cycles, n_d))
        if self.part_noise > 0:  # drawn last: series without it keep their seeds' draws
            rows = layout.tools if layout.tools.size else np.arange(n_r)
            noise = noise + rng.normal(0.0, self.part_noise, size=(self.n_cycles, rows.size)) @ C[rows]
        # Effects that do not depend on the applied corrections are fixed in advance.
        probe = Series(
            np.zeros((self.n_cycles, n_d)),
            times,
            np.zeros((self.n_cycles, n_r)),
            parts,
            temp_at,
            channels,
            process_channels=names,
        )
        static = np.zeros((self.n_cycles, n_d))
        rel = np.zeros_like(C)
        for e in effects:
            try:
                if e.spec.kind == "relation":
                    i = layout.register_ids.index(str(e.spec.register))
                    q = layout.dimension_ids.index(str(e.spec.dimension))
                    rel[i, q] += e.magnitude
                else:
                    static += e.magnitude * effect_field(e.spec, layout, probe)
            except (KeyError, ValueError, IndexError):
                raise ParameterError(
                    f"simulate: effect {e.spec.kind} names an unknown target ({e.spec.target})"
                ) from None
        true_C = C + rel
        pinv = np.linalg.pinv(C)  # (n_d, n_r): least-squares correction through the declared model
        state = np.zeros(n_r)  # sum of corrections applied so far
        pending: list[tuple[float, Array]] = []
        applied = np.zeros((self.n_cycles, n_r))
        dev = np.zeros((self.n_cycles, n_d))
        h = layout.resolution
        for k in range(self.n_cycles):
            while pending and pending[0][0] <= times[k]:
                state = state + pending.pop(0)[1]
            applied[k] = state
            dev[k] = (setup + state) @ true_C + static[k] + noise[k]
            if self.correct_every and (k + 1) % self.correct_every == 0:
                first = max(0, k + 1 - self.correct_every)
                planned = state + sum((p[1] for p in pending), np.zeros(n_r))
                # deviations as they would be with the registers already planned (no double correction)
                seen = dev[first : k + 1] + (planned - applied[first : k + 1]) @ C
                delta = -self.gain * (seen.mean(axis=0) @ pinv)
                if self.sparse and self.sparse < n_r:
                    delta[np.argsort(-np.abs(delta))[self.sparse :]] = 0.0
                delta = np.clip(np.round(delta / h) * h, -0.1, 0.1)
                if np.any(delta != 0):
                    at = float(times[k] + self.dead_time / 60.0)
                    pending.append((at, delta))
                    for reg in np.flatnonzero(delta):
                        log.append((at, int(reg), float(delta[reg]), "correction"))
        leftover: Array = np.sum([p[1] for p in pending], axis=0) if pending else np.zeros(n_r)
        dev = np.round(dev, self.decimals)
        log.sort(key=lambda r: r[0])
        series = Series(
            dev,
            times,
            applied,
            parts,
            temp_at,
            channels,
            tuple(f"cycle {k + 1:03d}" for k in range(self.n_cycles)),
            "",
            leftover,
            names,
        )
        return SimulatedSeries(
            series=series,
            log_time=np.array([r[0] for r in log], dtype=float),
            log_register=np.array([r[1] for r in log], dtype=np.intp),
            log_delta=np.array([r[2] for r in log], dtype=float),
            log_event=tuple(r[3] for r in log),
            temp_time=t_temp,
            temp=temp,
            setup_error=setup,
            effects=effects,
            noise=self.noise,
            truth={
                "effects": [{"kind": e.spec.kind, "target": e.spec.target, "magnitude": e.magnitude} for e in effects]
            },
        )


def random_topology(seed: int | None = None, *, positions: bool = True) -> dict[str, Any]:
    """A random process-model document (the model file contract) for tests and benches.

    2–6 WKS, 1–4 tools, 6–16 features (each moved by one WKS and one tool, weights
    ±1), 8–24 dimensions of one feature or the difference of two, nominal sizes
    5–120, 2–4 groups, feature positions in a 400 × 300 × 100 box.
    """
    rng = generator(seed)
    n_w, n_t = int(rng.integers(2, 7)), int(rng.integers(1, 5))
    n_f, n_d = int(rng.integers(6, 17)), int(rng.integers(8, 25))
    n_g = int(rng.integers(2, 5))
    doc: dict[str, Any] = {
        "process": {"name": f"random topology {seed}", "axis": "Z", "unit": "mm"},
        "wks": {f"W{i + 1}": {"register": f"G{54 + i}"} for i in range(n_w)},
        "tools": {f"T{i + 1}": {"register": f"H{i + 1}"} for i in range(n_t)},
        "features": {},
        "dimensions": {},
    }
    for f in range(n_f):
        feat: dict[str, Any] = {
            "wks": {f"W{int(rng.integers(n_w)) + 1}": int(rng.choice([-1, 1]))},
            "tools": {f"T{int(rng.integers(n_t)) + 1}": int(rng.choice([-1, 1]))},
        }
        if positions:
            feat["position"] = [
                float(np.round(rng.uniform(0, 400), 1)),
                float(np.round(rng.uniform(0, 300), 1)),
                float(np.round(rng.uniform(0, 100), 1)),
            ]
        doc["features"][f"F{f + 1}"] = feat
    for d in range(n_d):
        a = int(rng.integers(n_f))
        feats = {f"F{a + 1}": 1}
        if rng.random() < 0.4:
            b = int(rng.integers(n_f))
            if b != a:
                feats[f"F{b + 1}"] = -1
        doc["dimensions"][f"D{d + 1}"] = {
            "name": f"D{d + 1}",
            "features": feats,
            "nominal": float(np.round(rng.uniform(5, 120), 1)),
            "lower": -0.1,
            "upper": 0.1,
            "group": f"S{d % n_g + 1}",
        }
    return doc


def _at_cycle(e: HiddenEffect, times: Array) -> HiddenEffect:
    """A level step given by its cycle (``cycle = "cycle N"``, ``at`` unset) placed at that cycle's time."""
    c = e.spec.cycle or ""
    if e.spec.kind != "level" or e.spec.at or not c.startswith("cycle ") or not c[6:].isdigit():
        return e
    k = int(c[6:])
    if not 1 <= k <= len(times):
        raise ParameterError(f"simulate: a level step at cycle {k} is not within the series (1 … {len(times)})")
    return dataclasses.replace(e, spec=dataclasses.replace(e.spec, at=float(times[k - 1])))
