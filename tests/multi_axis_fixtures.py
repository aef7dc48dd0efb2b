"""Generated held-out multi-axis fixtures (issue 23): a model, a report, and the spec's equations by hand.

Each fixture has two stations (WKS W1, W2 corrected in X, Y, Z and rotated about Z), an end mill
T1 with a radius register and a drill T2; per station features at random positions with random
per-component weights (a tombstone's 180° side is x = −1, y = 1, z = −1), lengths along an axis
or a random direction, sizes moved by the radius only, and circular position zones in XY or XZ.
The measured deviations are a drawn setup error pushed through the spec's equations, written out
here without setupfix (:func:`change_matrix`), plus noise.  :func:`independent_optimum` solves the
maximin of the true (circle) margins on the register grids with scipy's MILP (HiGHS) on its own
formulation: every zone an inscribed 720-gon of the circle of radius R − t.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypedDict

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

AXES = ("X", "Y", "Z")
UNIT = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}
RES, LIMIT, ROT_RES, ROT_LIMIT, RADIUS_LIMIT = 0.001, 0.1, 0.0001, 0.03, 0.05
SIDES = 720


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
    lines = ["characteristic,nominal,actual,deviation,lower,upper,unit,part"]
    for name, dev, lo, up in fx.rows:
        lims = ("", "") if math.isnan(lo) else (repr(lo), repr(up))
        lines.append(f"{name},0.0,{dev!r},{dev!r},{lims[0]},{lims[1]},mm,cycle 1")
    return "\n".join(lines) + "\n"


def true_margins(fx: Fixture, values: np.ndarray) -> np.ndarray:
    """Every dimension's margin after register values (degrees for .C): the circle's for a zone."""
    out = []
    for d in fx.dims:
        if d["kind"] == "position":
            v = d["deviation"] + values @ d["columns"]
            out.append(d["diameter"] / 2 - math.hypot(*v))
        else:
            p = d["deviation"] + values @ d["column"]
            out.append(min(p - d["lower"], d["upper"] - p))
    return np.array(out)


def independent_optimum(fx: Fixture) -> tuple[float, np.ndarray]:
    """max over the register grids of the smallest true margin (scipy.optimize.milp on integer steps).

    Returns the MILP optimum t (a lower bound of the true one, within ‖v‖(1/cos(π/720) − 1) of it)
    and the register values reaching it.
    """
    n = len(fx.registers)
    kmax = np.floor(fx.limits / fx.steps + 1e-9)
    rows, lo, hi = [], [], []

    def add(coef: np.ndarray, tcoef: float, low: float, high: float) -> None:
        rows.append(np.concatenate([coef, [tcoef]]))
        lo.append(low)
        hi.append(high)

    for d in fx.dims:
        if d["kind"] == "position":
            r = d["diameter"] / 2
            c = math.cos(math.pi / SIDES)
            for j in range(SIDES):
                a = 2 * math.pi * j / SIDES
                nj = np.array([math.cos(a), math.sin(a)])
                # n_j·(δ + Σ col k·step) ≤ (R − t) cos(π/K)
                add((d["columns"] @ nj) * fx.steps, c, -np.inf, r * c - nj @ d["deviation"])
            continue
        col = d["column"] * fx.steps
        add(col, -1.0, d["lower"] - d["deviation"], np.inf)  # dev + Ck − lower ≥ t
        add(-col, -1.0, d["deviation"] - d["upper"], np.inf)  # upper − dev − Ck ≥ t
    A = np.array(rows)
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    res = milp(
        cost,
        constraints=LinearConstraint(A, lo, hi),
        integrality=np.r_[np.ones(n), 0],
        bounds=Bounds(np.r_[-kmax, -1.0], np.r_[kmax, 1.0]),
        options={"mip_rel_gap": 0, "time_limit": 60},
    )
    assert res.status == 0, res.message
    return float(-res.fun), np.rint(res.x[:n]) * fx.steps
