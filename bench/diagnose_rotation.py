"""Rotated plates: is a WKS rotation about the spindle named, sized and does it predict held-out holes?

A drilled plate (``plate_doc``: holes spread over a disc of radius 300 mm, X and Y positions
of each hole measured, one WKS with X and Y translations and no rotation register) is measured
once, turned by θ (100–800 µrad) about the spindle axis through a centre off the WKS origin,
with a setup offset and measurement noise σ = 0.006 mm per coordinate (the rigid-fit residual
of the plates issue 41 reports).  A: the diagnosis of the whole plate — kind named and
|θ̂ − θ| / θ.  B: held out — the diagnosis of one half of the holes (every other hole), its
effects carried to the other half: RMS of the other half after its own translation against
the rigid fit's residual (rotation and translation fitted on all holes).

Run: ``python -m bench.diagnose_rotation`` → ``bench/results/diagnose_rotation.txt``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from setupfix.diagnose import Diagnoser, Layout, Series
from setupfix.model import ProcessModel, model_from_dict

__all__ = ["plate_doc", "plate", "rotated_plate", "held_out", "rigid_rms", "NOISE"]

#: Measurement noise per coordinate [mm].
NOISE = 0.006
RADIUS = 300.0


def plate_doc(n_holes: int, seed: int) -> dict[str, Any]:
    """A multi-axis plate model: ``n_holes`` holes at random on a disc, their X and Y measured."""
    rng = np.random.default_rng(seed)
    r = RADIUS * np.sqrt(rng.uniform(0.05, 1.0, n_holes))
    a = rng.uniform(0, 2 * np.pi, n_holes)
    xy = np.round(np.column_stack([r * np.cos(a), r * np.sin(a)]), 3)
    doc: dict[str, Any] = {
        "process": {"name": f"plate {seed}", "axes": ["X", "Y", "Z"], "spindle": "Z", "unit": "mm", "limit": 1.0},
        "wks": {"W1": {"register": "G54"}},
        "tools": {"T1": {"register": "H1"}},
        "features": {},
        "dimensions": {},
    }
    for i, (x, y) in enumerate(xy, start=1):
        doc["features"][f"H{i}"] = {"wks": {"W1": 1}, "position": [float(x), float(y), 0.0]}
        for axis, nominal in (("X", x), ("Y", y)):
            doc["dimensions"][f"H{i}{axis}"] = {
                "features": {f"H{i}": 1},
                "axis": axis,
                "nominal": float(nominal),
                "lower": -0.1,
                "upper": 0.1,
            }
    return doc


def plate(n_holes: int, seed: int) -> ProcessModel:
    return model_from_dict(plate_doc(n_holes, seed), source=f"plate {seed}")


def rotated_plate(layout: Layout, theta: float, seed: int, noise: float = NOISE) -> Series:
    """One measurement of the plate turned by ``theta`` [rad] about a centre off the WKS origin, shifted
    and noisy: δx = −θ (y − c_y) + t_x, δy = θ (x − c_x) + t_y (computed from the coordinates, not from
    the layout's rotation field)."""
    rng = np.random.default_rng(10_000 + seed)
    centre = rng.uniform(-50, 50, 2)
    shift = rng.uniform(-0.05, 0.05, 2)
    x, y = layout.coord[:, 0], layout.coord[:, 1]
    n = np.nan_to_num(layout.direction)
    dev = n[:, 0] * (-theta * (y - centre[1]) + shift[0]) + n[:, 1] * (theta * (x - centre[0]) + shift[1])
    dev = np.round(dev + rng.normal(0, noise, dev.size), 4)[None, :]
    n_r = layout.n_registers
    return Series(dev, np.zeros(1), np.zeros((1, n_r)), np.zeros((1, layout.tools.size)), np.zeros((1, 0)))


def rigid_rms(layout: Layout, series: Series) -> float:
    """RMS residual of the rigid fit (translation X, Y and rotation about Z) of every hole, by least squares
    on the coordinates."""
    n = np.nan_to_num(layout.direction)
    x, y = layout.coord[:, 0], layout.coord[:, 1]
    X = np.column_stack([n[:, 0], n[:, 1], -n[:, 0] * y + n[:, 1] * x])
    z = series.deviation[0]
    coef = np.linalg.lstsq(X, z, rcond=None)[0]
    return float(np.sqrt(np.mean((z - X @ coef) ** 2)))


def held_out(model_doc: dict[str, Any], series: Series, layout: Layout) -> tuple[float, float]:
    """Diagnose every other hole, carry the effects found to the other half (its translation refitted).

    Returns (RMS of the held-out half after its translation only, RMS with the effects found carried).
    """
    ids = [f"H{i}" for i in range(1, len(model_doc["features"]) + 1)]
    train = set(ids[0::2])
    doc = dict(model_doc)
    doc["features"] = {k: v for k, v in model_doc["features"].items() if k in train}
    doc["dimensions"] = {
        k: v for k, v in model_doc["dimensions"].items() if k[: k.rindex("X" if k.endswith("X") else "Y")] in train
    }
    sub = Layout.from_model(model_from_dict(doc, source="train half"))
    cols = [layout.dimension_ids.index(d) for d in sub.dimension_ids]
    train_series = Series(series.deviation[:, cols], series.time, series.applied, series.parts, series.temperature)
    d = Diagnoser(walk=False).run(sub, train_series)
    test = [q for q in range(layout.n_dimensions) if layout.dimension_ids[q] not in set(sub.dimension_ids)]
    z = series.deviation[0, test]
    pred = np.zeros(len(test))
    for e in d.effects:
        if e.kind == "rotation":
            pred += e.estimate * layout.rotation[layout.rotation_ids.index(str(e.spec.register))][test]
    n = np.nan_to_num(layout.direction[test])
    base = n[:, :2]

    def after_translation(r: np.ndarray) -> float:
        t = np.linalg.lstsq(base, r, rcond=None)[0]
        return float(np.sqrt(np.mean((r - base @ t) ** 2)))

    return after_translation(z), after_translation(z - pred)


def main() -> None:
    lines = [
        "Rotated plates (bench/diagnose_rotation.py): 80 holes on a 300 mm disc, X and Y measured, one report,",
        f"noise {NOISE} mm per coordinate, turned about a centre off the WKS origin.",
        "",
        f"{'seed':>4} {'theta urad':>10} {'named':>8} {'found urad':>11} {'rel err':>8} "
        f"{'rigid':>8} {'held: shift':>12} {'held: found':>12} {'ratio':>6}",
    ]
    for seed in range(12):
        theta = (100.0 + 700.0 * seed / 11) * 1e-6
        doc = plate_doc(80, seed)
        layout = Layout.from_model(model_from_dict(doc, source="plate"))
        s = rotated_plate(layout, theta, seed)
        d = Diagnoser(walk=False).run(layout, s)
        rot = [e for e in d.effects if e.kind == "rotation"]
        est = rot[0].estimate if rot else float("nan")
        rigid = rigid_rms(layout, s)
        shift_only, carried = held_out(doc, s, layout)
        lines.append(
            f"{seed:>4} {theta * 1e6:>10.0f} {','.join(e.kind for e in d.effects) or '-':>8} {est * 1e6:>11.1f} "
            f"{abs(est - theta) / theta:>8.3f} {rigid:>8.4f} {shift_only:>12.4f} {carried:>12.4f} "
            f"{carried / rigid:>6.2f}"
        )
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    out = Path(__file__).parent / "results" / "diagnose_rotation.txt"
    out.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
