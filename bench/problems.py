"""The problems and reports the benches solve, made here once for all of them.

* :func:`make_reports`: copies of the five bundled guide-pins cycles as report files, what
  ``setupfix batch`` reads (``bench.batch_throughput`` and the benches that run the batch);
* :func:`guide_pins_problems`: the paper's example, the five cycles and random measurement sets by
  eqs. 12-13 (``bench.exact_per_report`` and the leximin benches);
* :func:`shop_problem`: random multi-part fixtures at shop scale, up to 300 registers x 5,000
  dimensions (``bench.exact_scaling``, the leximin and triage benches);
* :func:`make_fixture`, :func:`report_csv`: generated two-station multi-axis fixtures, a model and a
  report (``bench.leximin_speed --only-multi-axis``).  The same generator is in
  ``tests/multi_axis_fixtures.py`` (with the tests' own hand-written solution): the tests do not
  import the benches, and ``tests`` is not a package the benches can import.
"""

from __future__ import annotations

import csv
import io
import math
import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from setupfix.correction.synthetic import simulate_deviations
from setupfix.inputs.cycles import load_parts
from setupfix.model import PartMeasurement, load_model
from setupfix.optimize import CorrectionProblem

ROOT = Path(__file__).resolve().parents[1]
#: The bundled guide-pins sample: the paper's example (10 registers x 28 dimensions), five cycles.
GUIDE = ROOT / "sample_reports" / "guide_pins"


def _varied(text: str, rng: random.Random) -> str:
    """The cycle with each actual moved by a uniform step in ±0.005 mm (4 decimals), deviation recomputed."""
    rows = list(csv.DictReader(io.StringIO(text, newline="")))
    for row in rows:
        actual = round(float(row["actual"]) + rng.uniform(-0.005, 0.005), 4)
        row["actual"] = f"{actual:.4f}"
        row["deviation"] = f"{actual - float(row['nominal']):.4f}"
    out = io.StringIO(newline="")
    writer = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def make_reports(folder: Path, n: int, vary: bool = False) -> None:
    """n report files ``r00000.csv``... in ``folder``: the five guide-pins cycles in turn, one second apart;
    with ``vary``, each actual moved by a random step in ±0.005 mm (seeded: the same files every run)."""
    texts = [(GUIDE / f"cycle_0{i}.csv").read_text() for i in range(1, 6)]
    rng = random.Random(0)
    for k in range(n):
        text = texts[k % 5].replace("T08:00:00", f"T{8 + (k // 3600) % 12:02d}:{(k // 60) % 60:02d}:{k % 60:02d}")
        (folder / f"r{k:05d}.csv").write_text(_varied(text, rng) if vary else text)


def guide_pins_problems(sets: int, seed: int) -> list[tuple[str, CorrectionProblem]]:
    """(label, problem): the five bundled guide-pins cycles, then ``sets`` random measurement sets drawn by
    eqs. 12-13 as in Fig. 18 (w1 = 0.03 mm, w2 = 0.02 mm)."""
    model = load_model(GUIDE / "model.toml")
    out = []
    for i in range(1, 6):
        for part in load_parts(model, GUIDE / f"cycle_{i:02d}.csv"):
            out.append((f"cycle_{i:02d}", CorrectionProblem.from_part(model, part)))
    devs, _ = simulate_deviations(model, sets, w1=0.03, w2=0.02, seed=seed)
    for s, dev in enumerate(devs):
        part = PartMeasurement(
            part=f"set {s + 1}", report="eqs. 12-13", timestamp=None, deviation=dev, sources=("",) * dev.size
        )
        out.append((f"set {s + 1}", CorrectionProblem.from_part(model, part)))
    return out


def shop_problem(n: int, m: int, seed: int, noise: float = 0.01) -> CorrectionProblem:
    """A random multi-part fixture with n registers and m measured dimensions.

    Shaped like the paper's (and like ``../shared/repro``): two thirds of the registers are WKS, one
    third tools; every feature is cut by one tool in one WKS (weights ±1); 70 % of the dimensions
    measure one feature, 30 % the difference of two; asymmetric tolerances of 0.02-0.1 mm per side;
    register limits ±0.1 mm on a 0.001 mm grid; measurement sets by eqs. 12-13 (w1 = 0.03 mm,
    w2 = ``noise``, 0.01 mm unless given), rounded to 0.1 µm.  A larger ``noise`` (the triage benches'
    ±0.045 mm) leaves some dimensions out of tolerance whatever the correction.
    """
    rng = np.random.default_rng(seed)
    n_wks = max(1, 2 * n // 3)
    n_feat = max(2, m)
    feat = np.zeros((n, n_feat))
    sign = rng.choice([-1.0, 1.0], n_feat)
    feat[rng.integers(0, n_wks, n_feat), np.arange(n_feat)] = sign
    feat[n_wks + rng.integers(0, n - n_wks, n_feat), np.arange(n_feat)] = sign
    comp = feat[:, rng.permutation(n_feat)[:m]].copy()
    pairs = rng.random(m) < 0.3
    other = feat[:, rng.integers(0, n_feat, m)]
    comp[:, pairs] -= other[:, pairs]
    lower = -np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    upper = np.round(rng.uniform(0.02, 0.1, m) / 0.005) * 0.005
    setup = 0.03 * (1 - 2 * rng.random(n))
    dev = np.round(setup @ comp + noise * (1 - 2 * rng.random(m)), 4)
    return CorrectionProblem(
        composite=comp,
        deviation=dev,
        lower=lower,
        upper=upper,
        lb=np.full(n, -0.1),
        ub=np.full(n, 0.1),
        resolution=0.001,
        register_ids=tuple(f"R{i}" for i in range(n)),
        dimension_ids=tuple(f"D{j}" for j in range(m)),
    )


# Generated two-station multi-axis fixtures (issue 23), as tests/multi_axis_fixtures.py makes them: two
# stations (WKS W1, W2 corrected in X, Y, Z and rotated about Z), an end mill T1 with a radius register
# and a drill T2; per station features at random positions with random per-component weights (a
# tombstone's 180° side is x = −1, y = 1, z = −1), lengths along an axis or a random direction, sizes
# moved by the radius only, and circular position zones in XY or XZ.  The measured deviations are a
# drawn setup error pushed through the spec's equations, written out here without setupfix
# (:func:`change_matrix`), plus noise.

AXES = ("X", "Y", "Z")
UNIT = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
RES, LIMIT, ROT_RES, ROT_LIMIT, RADIUS_LIMIT = 0.001, 0.1, 0.0001, 0.03, 0.05


class Feature(TypedDict):
    pos: np.ndarray  # x, y, z
    comp: dict[str, float]  # per-component weight of its WKS (x, y, z, c)
    length: dict[str, float]  # tool -> length weight
    radius: dict[str, float]  # tool -> radius weight
    wks: str


#: A dimension: its keys depend on its kind (length, size or position) and the generator fills in its
#: column(s) and deviation (a float, or a δ pair for a position), so a plain mapping by key.
Dimension = dict[str, Any]


@dataclass
class Fixture:
    text: str  # the model TOML
    rows: list[tuple[str, float, float, float]]  # report rows: name, deviation, lower, upper
    registers: list[str]
    steps: np.ndarray  # grid step of each register (degrees for .C)
    limits: np.ndarray
    dims: list[Dimension]  # name, kind, lower, upper | radius, deviation (or δ pair), column(s)


def _features(rng: np.random.Generator, station: str) -> dict[str, Feature]:
    feats: dict[str, Feature] = {}
    for i in range(6):
        pos = np.round(rng.uniform(-60, 60, 3), 1)
        tombstone = rng.random() < 0.3  # the 180° side of a tombstone
        comp = {"x": -1.0, "y": 1.0, "z": -1.0, "c": -1.0} if tombstone else dict.fromkeys("xyzc", 1.0)
        length = {"T1": 1.0} if i % 3 == 0 else ({"T2": 1.0} if i % 3 == 1 else {})
        radius = {"T1": float(rng.choice([-1.0, 1.0]))} if i % 2 == 0 else {}
        feats[f"{station}F{i}"] = {
            "pos": pos,
            "comp": comp,
            "length": length,
            "radius": radius,
            "wks": f"W{station[1]}",
        }
    return feats


def _dimensions(rng: np.random.Generator, station: str, feats: dict[str, Feature]) -> list[Dimension]:
    ids = list(feats)
    out: list[Dimension] = []
    for k in range(3):  # lengths along an axis or a direction
        fs = {ids[k]: 1.0} if k != 2 else {ids[2]: 1.0, ids[3]: -1.0}
        direction: str | tuple[float, ...]  # an axis name or a unit vector
        if k == 1:
            v = rng.normal(size=3)
            direction = tuple(np.round(v / np.linalg.norm(v), 6))
            n = np.array(direction) / np.linalg.norm(direction)
        else:
            axis = AXES[int(rng.integers(3))]
            direction, n = axis, UNIT[axis]
        tol = float(rng.choice([0.04, 0.05, 0.08]))
        out.append(
            {
                "name": f"{station} L{k}",
                "kind": "length",
                "features": fs,
                "n": n,
                "direction": direction,
                "lower": -tol,
                "upper": tol,
            }
        )
    out.append(
        {
            "name": f"{station} S0",
            "kind": "size",
            "features": {ids[0]: 2.0},
            "n": None,
            "direction": None,
            "lower": -0.03,
            "upper": 0.03,
        }
    )
    for k, plane in enumerate((("X", "Y"), ("X", "Z"))):
        out.append(
            {
                "name": f"{station} Z{k}",
                "kind": "position",
                "features": {ids[4 + k]: 1.0},
                "plane": plane,
                "diameter": float(rng.choice([0.08, 0.1, 0.14])),
            }
        )
    return out


def _shift(f: Feature, reg: str) -> tuple[np.ndarray, float]:
    """Displacement of feature f per unit of register component ``reg`` and its radius term (spec)."""
    s = UNIT["Z"]
    if reg.startswith("W"):
        w, comp = reg.split(".")
        if f["wks"] != w:
            return np.zeros(3), 0.0
        if comp == "C":
            return f["comp"]["c"] * math.pi / 180 * np.cross(s, f["pos"]), 0.0
        return f["comp"][comp.lower()] * UNIT[comp], 0.0
    if reg.endswith(".R"):
        return np.zeros(3), f["radius"].get(reg[:-2], 0.0)
    return f["length"].get(reg, 0.0) * s, 0.0


def change_matrix(registers: list[str], feats: dict[str, Feature], dims: list[Dimension]) -> None:
    """Each dimension's column(s): d_q = Σ_f w_qf (n_q·p_f + Σ ρ r) per unit register (sizes: ρ only)."""
    for d in dims:
        if d["kind"] == "position":
            d["columns"] = np.array(
                [
                    [
                        sum(
                            w * (UNIT[a] @ _shift(feats[f], r)[0] + _shift(feats[f], r)[1])
                            for f, w in d["features"].items()
                        )
                        for a in d["plane"]
                    ]
                    for r in registers
                ]
            )  # (R, 2)
            continue
        col = []
        for r in registers:
            total = 0.0
            for f, w in d["features"].items():
                p, rho = _shift(feats[f], r)
                total += w * ((0.0 if d["kind"] == "size" else d["n"] @ p) + rho)
            col.append(total)
        d["column"] = np.array(col)


def make_fixture(seed: int) -> Fixture:
    rng = np.random.default_rng(seed)
    feats = {**_features(rng, "P1"), **_features(rng, "P2")}
    dims = _dimensions(rng, "P1", feats) + _dimensions(rng, "P2", feats)
    registers = [f"W{s}.{c}" for s in "12" for c in "XYZC"] + ["T1", "T1.R", "T2"]
    steps = np.array([ROT_RES if r.endswith(".C") else RES for r in registers])
    limits = np.array(
        [ROT_LIMIT if r.endswith(".C") else RADIUS_LIMIT if r.endswith(".R") else LIMIT for r in registers]
    )
    change_matrix(registers, feats, dims)
    error = rng.uniform(-0.6, 0.6, len(registers)) * limits  # a setup error the registers can undo
    rows = []
    for d in dims:
        if d["kind"] == "position":
            dev = error @ d["columns"] + rng.normal(0, 0.004, 2)
            d["deviation"] = dev
            rows += [(f"{d['name']} {a}", float(v), math.nan, math.nan) for a, v in zip(d["plane"], dev, strict=True)]
        else:
            dev = float(error @ d["column"] + rng.normal(0, 0.004))
            d["deviation"] = dev
            rows.append((d["name"], dev, d["lower"], d["upper"]))
    return Fixture(_toml(feats, dims), rows, registers, steps, limits, dims)


def _toml(feats: dict[str, Feature], dims: list[Dimension]) -> str:
    out = [
        "[process]",
        'name = "generated two-station fixture"',
        'axes = ["X", "Y", "Z"]',
        "rotation = true",
        f"resolution = {RES}",
        f"limit = {LIMIT}",
        f"rotation_limit = {ROT_LIMIT}",
        f"rotation_resolution = {ROT_RES}",
        "",
        '[wks.W1]\nregister = "G54"',
        '[wks.W2]\nregister = "G55"',
        f'[tools.T1]\nregister = "H1"\nradius = "D1"\nradius_limit = {RADIUS_LIMIT}',
        '[tools.T2]\nregister = "H2"',
    ]
    for fid, f in feats.items():
        comp = ", ".join(f"{k} = {v}" for k, v in f["comp"].items())
        out += [
            f"[features.{fid}]",
            f"wks = {{ {f['wks']} = {{ {comp} }} }}",
            f"position = [{f['pos'][0]}, {f['pos'][1]}, {f['pos'][2]}]",
        ]
        if f["length"]:
            out.append("tools = { " + ", ".join(f"{t} = {w}" for t, w in f["length"].items()) + " }")
        if f["radius"]:
            out.append("radius = { " + ", ".join(f"{t} = {w}" for t, w in f["radius"].items()) + " }")
    for i, d in enumerate(dims):
        fs = "{ " + ", ".join(f"{f} = {w}" for f, w in d["features"].items()) + " }"
        out += [f"[dimensions.D{i}]", f'name = "{d["name"]}"', f"features = {fs}"]
        if d["kind"] == "position":
            out += [
                'kind = "position"',
                f'components = ["{d["name"]} {d["plane"][0]}", "{d["name"]} {d["plane"][1]}"]',
                f'axes = ["{d["plane"][0]}", "{d["plane"][1]}"]',
                f"diameter = {d['diameter']}",
            ]
            continue
        if d["kind"] == "size":
            out.append('kind = "size"')
        elif isinstance(d["direction"], str):
            out.append(f'axis = "{d["direction"]}"')
        else:
            out.append("direction = [" + ", ".join(repr(float(v)) for v in d["direction"]) + "]")
        out += ["nominal = 0.0", f"lower = {d['lower']}", f"upper = {d['upper']}"]
    return "\n".join(out) + "\n"


def report_csv(fx: Fixture) -> str:
    """The fixture's measurements as a report in the canonical CSV layout (one cycle)."""
    lines = ["characteristic,nominal,actual,deviation,lower,upper,unit,part"]
    for name, dev, lo, up in fx.rows:
        lims = ("", "") if math.isnan(lo) else (repr(lo), repr(up))
        lines.append(f"{name},0.0,{dev!r},{dev!r},{lims[0]},{lims[1]},mm,cycle 1")
    return "\n".join(lines) + "\n"
