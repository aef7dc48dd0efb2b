"""Use case "simulate": a closed-loop shop series written in the canonical formats.

Writes into one folder (``../shared/spec/measurements.md``):

* ``measurements.csv`` — the canonical measurement table, one ``part`` per cycle
  (or ``cycle_001.csv`` … with ``per_cycle``), station = the dimension's group,
  x/y/z where the model gives feature positions;
* ``corrections.csv`` — the corrections log (timestamp, register, delta, event);
* ``temperatures.csv`` — the temperature log (timestamp, spindle, ambient);
* ``truth.json`` — the hidden effects, the setup error and every setting, so that a
  diagnosis can be checked.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np

from setupfix.core.errors import ExportError, ParameterError
from setupfix.diagnose import KINDS, EffectSpec, HiddenEffect, Layout, ShopSimulator, SimulatedSeries
from setupfix.model import ProcessModel, load_model
from setupfix.outputs.writers import atomic_write, check_target

__all__ = ["parse_effect", "SimulateOutcome", "simulate_series", "write_series"]

_EFFECT_KEYS = (
    "kind",
    "magnitude",
    "register",
    "dimension",
    "axis",
    "group",
    "channel",
    "shape",
    "tau",
    "reference",
    "at",
)
START = "2026-11-02T06:00:00"


def parse_effect(text: str) -> HiddenEffect:
    """``kind=wear,register=T5,magnitude=-0.001`` → :class:`HiddenEffect`.

    Keys: kind (required), magnitude (required), register, dimension, axis, group,
    channel (default spindle), shape (linear | saturating), tau [h], reference [°C,
    default 20], at (a level step: the cycle, counted from 1, it starts at).

    Raises
    ------
    ParameterError
        On an unknown key, kind or a value that is not a number.
    """
    items: dict[str, str] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise ParameterError(f"--effect {text!r}: expected key=value pairs, e.g. kind=drift,magnitude=0.002")
        k, v = (s.strip() for s in part.split("=", 1))
        if k not in _EFFECT_KEYS:
            raise ParameterError(f"--effect {text!r}: unknown key {k!r} (known: {', '.join(_EFFECT_KEYS)})")
        items[k] = v
    kind = items.get("kind")
    if kind not in KINDS:
        raise ParameterError(f"--effect {text!r}: kind must be one of {', '.join(KINDS)}, got {kind!r}")
    try:
        magnitude = float(items["magnitude"])
        tau = float(items.get("tau", "4"))
        reference = float(items.get("reference", "20"))
    except KeyError:
        raise ParameterError(f"--effect {text!r}: magnitude is required") from None
    except ValueError as exc:
        raise ParameterError(f"--effect {text!r}: {exc}") from None
    shape = items.get("shape", "linear")
    if shape not in ("linear", "saturating"):
        raise ParameterError(f"--effect {text!r}: shape must be linear or saturating, got {shape!r}")
    if not (np.isfinite(magnitude) and np.isfinite(tau) and tau > 0):
        raise ParameterError(f"--effect {text!r}: magnitude and tau must be finite, tau > 0")
    channel = items.get("channel", "spindle" if kind == "thermal" else None)
    cycle = None
    if kind == "level":
        at = items.get("at", "")
        if not at.isdigit() or int(at) < 1:
            raise ParameterError(f"--effect {text!r}: a level step needs at=N, the cycle it starts at (1, 2, …)")
        cycle = f"cycle {int(at)}"
    elif "at" in items:
        raise ParameterError(f"--effect {text!r}: at= is for a level step only")
    spec = EffectSpec(
        kind,
        register=items.get("register"),
        dimension=items.get("dimension"),
        axis=items.get("axis"),
        group=items.get("group"),
        channel=channel,
        shape=shape,
        tau=tau,
        reference=reference,
        cycle=cycle,
    )
    return HiddenEffect(spec, magnitude)


@dataclass(frozen=True)
class SimulateOutcome:
    """A simulated series and the files written."""

    model: ProcessModel
    simulated: SimulatedSeries
    files: tuple[str, ...]
    start: str


def simulate_series(
    model: ProcessModel | str | Path, effects: list[HiddenEffect] | tuple[HiddenEffect, ...] = (), **params: Any
) -> tuple[ProcessModel, Layout, SimulatedSeries]:
    """Run the shop simulator on a model (path or loaded)."""
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    layout = Layout.from_model(model)
    sim = ShopSimulator(**params).run(layout, tuple(effects))
    return model, layout, sim


def _stamp(start: datetime, hours: float) -> str:
    return (start + timedelta(hours=float(hours))).isoformat(timespec="seconds")


def write_series(
    model: ProcessModel,
    layout: Layout,
    sim: SimulatedSeries,
    out_dir: str | Path,
    *,
    per_cycle: bool = False,
    start: str = START,
    settings: dict[str, Any] | None = None,
) -> tuple[str, ...]:
    """Write the series into ``out_dir`` (created if needed); return the files written.

    Raises
    ------
    ExportError
        If the folder cannot be created or a file cannot be written.
    """
    out = Path(out_dir)
    try:
        t0 = datetime.fromisoformat(start)
    except ValueError:
        raise ParameterError(f"--start {start!r}: expected an ISO 8601 date-time") from None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"cannot create the folder: {exc.strerror}") from None
    if not out.is_dir():
        raise ExportError(f"{out} is not a folder")
    names = ["measurements.csv"] if not per_cycle else [f"cycle_{k + 1:03d}.csv" for k in range(sim.series.n_cycles)]
    for name in [*names, "corrections.csv", "temperatures.csv", "truth.json"]:
        check_target(out / name)
    s = sim.series
    header = [
        "characteristic",
        "nominal",
        "actual",
        "deviation",
        "lower",
        "upper",
        "unit",
        "part",
        "timestamp",
        "station",
    ]
    has_xyz = np.isfinite(layout.coord).all()
    if has_xyz:
        header += ["x", "y", "z"]
    written: list[str] = []

    def rows(k: int) -> list[list[str]]:
        r = []
        for q, dim in enumerate(model.dimensions):
            dev = s.deviation[k, q]
            row = [
                dim.name,
                f"{dim.nominal:.6f}",
                f"{dim.nominal + dev:.6f}",
                f"{dev:.6f}",
                f"{dim.lower:g}",
                f"{dim.upper:g}",
                model.unit,
                s.cycles[k],
                _stamp(t0, s.time[k]),
                dim.group or "",
            ]
            if has_xyz:
                row += [f"{v:.6g}" for v in layout.coord[q]]
            r.append(row)
        return r

    groups = [list(range(s.n_cycles))] if not per_cycle else [[k] for k in range(s.n_cycles)]
    for ks in groups:
        name = "measurements.csv" if not per_cycle else f"cycle_{ks[0] + 1:03d}.csv"
        with atomic_write(out / name) as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(header)
            for k in ks:
                w.writerows(rows(k))
        written.append(str(out / name))
    with atomic_write(out / "corrections.csv") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["timestamp", "register", "delta", "event"])
        for t, i, d, ev in zip(sim.log_time, sim.log_register, sim.log_delta, sim.log_event, strict=True):
            w.writerow([_stamp(t0, t), layout.register_ids[i], "" if ev == "tool_change" else f"{d:.6g}", ev])
    written.append(str(out / "corrections.csv"))
    with atomic_write(out / "temperatures.csv") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(["timestamp", *s.channels])
        for t, row in zip(sim.temp_time, sim.temp, strict=True):
            w.writerow([_stamp(t0, t), *(f"{v:.2f}" for v in row)])
    written.append(str(out / "temperatures.csv"))
    truth = {
        "model": model.source,
        "start": start,
        "hidden_effects": sim.truth.get("effects", []),
        "setup_error": dict(zip(layout.register_ids, (round(float(v), 6) for v in sim.setup_error), strict=True)),
        "noise": sim.noise,
        "settings": settings or {},
    }
    with atomic_write(out / "truth.json") as fh:
        json.dump(truth, fh, indent=2)
        fh.write("\n")
    written.append(str(out / "truth.json"))
    return tuple(written)
