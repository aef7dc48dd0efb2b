"""Shared test data for the diagnosis: the guide-pins model with feature positions, random topologies."""

from __future__ import annotations

import tomllib
from collections.abc import Iterable
from typing import Any, TypedDict, Unpack

import numpy as np
from conftest import GUIDE_PINS

from setupfix.diagnose import EffectSpec, HiddenEffect, Layout, ShopSimulator, SimulatedSeries
from setupfix.diagnose.shop import random_topology
from setupfix.model import ProcessModel, model_from_dict

NOISE = 0.002
EXPANDED = GUIDE_PINS.parents[1] / "tests" / "model" / "data" / "guide_pins_expanded.toml"


class SimulatorParams(TypedDict, total=False):
    """The keyword parameters of :class:`ShopSimulator` (the seed apart)."""

    n_cycles: int
    noise: float
    setup_error: float
    cycle_minutes: float
    shift_cycles: int
    pause_hours: float
    correct_every: int
    dead_time: float
    gain: float
    tool_change_every: int
    heat: float
    sparse: int
    decimals: int
    process: int
    part_noise: float


def guide_pins_doc(positions: bool = True) -> dict[str, Any]:
    """The bundled guide-pins model; with positions, part p sits at x = 150 (p − 1), feature f at +20 f."""
    doc = tomllib.loads(EXPANDED.read_text(encoding="utf-8"))  # the sample written table by table
    if positions:
        for fid, feat in doc["features"].items():
            p, f = int(fid[1]), int(fid[3:])
            feat["position"] = [150.0 * (p - 1) + 20.0 * f, 40.0 if f in (1, 2, 4) else -40.0, 10.0 * (f % 3)]
    return doc


def guide_pins(positions: bool = True) -> ProcessModel:
    return model_from_dict(guide_pins_doc(positions), source="guide_pins")


def topology(seed: int) -> ProcessModel:
    return model_from_dict(random_topology(seed), source=f"topology {seed}")


def one_effect(layout: Layout, kind: str, scale: float = 1.0) -> HiddenEffect:
    """A clearly detectable effect of ``kind`` on ``layout`` (magnitudes several times the noise)."""
    C = layout.composite
    if kind == "drift":
        return HiddenEffect(EffectSpec("drift"), 0.002 * scale)
    if kind == "saturating":
        return HiddenEffect(EffectSpec("drift", shape="saturating", tau=3.0), 0.02 * scale)
    if kind == "thermal":
        return HiddenEffect(EffectSpec("thermal", channel="spindle", reference=20.0), 0.003 * scale)
    if kind == "wear":
        return HiddenEffect(EffectSpec("wear", register=layout.tool_ids[0]), -0.001 * scale)
    if kind == "scale":
        return HiddenEffect(EffectSpec("scale"), 2e-4 * scale)
    if kind == "position":
        return HiddenEffect(EffectSpec("position", axis="x"), 5e-5 * scale)
    if kind == "group":
        return HiddenEffect(EffectSpec("group", group=sorted({g for g in layout.groups if g})[1]), 0.01 * scale)
    if kind == "relation":
        # a register the first dimension does not answer to in the model: a missing relation
        free = np.flatnonzero(C[:, 0] == 0)
        reg = layout.register_ids[int(free[0])] if free.size else layout.register_ids[0]
        return HiddenEffect(EffectSpec("relation", register=reg, dimension=layout.dimension_ids[0]), 0.5 * scale)
    raise KeyError(kind)


def simulate(
    layout: Layout, effects: Iterable[HiddenEffect] = (), seed: int = 0, **params: Unpack[SimulatorParams]
) -> SimulatedSeries:
    given: SimulatorParams = {"n_cycles": 40, "noise": NOISE, **params}
    return ShopSimulator(seed=seed, **given).run(layout, tuple(effects))
