"""Generated held-out multi-axis fixtures (issue 23): the true margins and an independent optimum.

Each fixture has two stations (WKS W1, W2 corrected in X, Y, Z and rotated about Z), an end mill
T1 with a radius register and a drill T2; per station features at random positions with random
per-component weights (a tombstone's 180° side is x = −1, y = 1, z = −1), lengths along an axis
or a random direction, sizes moved by the radius only, and circular position zones in XY or XZ.
The measured deviations are a drawn setup error pushed through the spec's equations, written out
here without setupfix (:func:`bench.problems.change_matrix`), plus noise; the generator is shared with the
benches (:mod:`bench.problems`).  :func:`independent_optimum` solves the
maximin of the true (circle) margins on the register grids with scipy's MILP (HiGHS) on its own
formulation: every zone an inscribed 720-gon of the circle of radius R − t.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

from bench.problems import Fixture, make_fixture, report_csv

SIDES = 720

__all__ = ["Fixture", "make_fixture", "report_csv", "true_margins", "independent_optimum"]


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
