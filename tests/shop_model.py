"""A shop-size fixture written as a model file and a canonical report (real files through every door).

``write_shop`` writes ``model.toml`` (``n_wks`` WKS, ``n_tools`` tools, one feature and one
dimension per characteristic, each moved by one WKS and one tool) and ``report.csv`` in
the canonical table, deviations seeded.  At 60 registers × 600 dimensions the exact
optimiser's LP bound takes longer than 1e-4 s, so a tiny ``--time-limit`` stops the solve
before anything is proved (a real problem, not a mock).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_shop(
    folder: Path, *, n_wks: int = 40, n_tools: int = 20, m: int = 600, seed: int = 3, name: str = "report.csv"
) -> tuple[Path, Path]:
    """Write the model and one report into ``folder``; returns (model path, report path)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    wks = rng.integers(0, n_wks, m)
    tool = rng.integers(0, n_tools, m)
    lines = ["[process]", 'name = "shop"', 'axis = "Z"', 'unit = "mm"', "resolution = 0.001", "limit = 0.1", ""]
    lines += [f'[wks.W{i}]\nregister = "G54.1P{i + 1}"\n' for i in range(n_wks)]
    lines += [f'[tools.T{i}]\nregister = "H{i + 1}"\n' for i in range(n_tools)]
    for q in range(m):
        lines += [f"[features.F{q}]", f"wks = {{W{wks[q]} = 1}}", f"tools = {{T{tool[q]} = 1}}", ""]
    for q in range(m):
        lines += [
            f"[dimensions.D{q}]",
            f'name = "SP_{q:03d}"',
            f"features = {{F{q} = 1}}",
            "nominal = 10.0",
            "lower = -0.05",
            "upper = 0.05",
            f'group = "S{wks[q]}"',
            "",
        ]
    model = folder / "model.toml"
    model.write_text("\n".join(lines), encoding="utf-8")
    dev = np.round(0.02 * (1 - 2 * rng.random(n_wks))[wks] + 0.01 * (1 - 2 * rng.random(m)), 4)
    rows = ["characteristic,nominal,actual,deviation,lower,upper,unit,part,station,timestamp"]
    rows += [
        f"SP_{q:03d},10.0000,{10 + dev[q]:.4f},{dev[q]:+.4f},-0.05,0.05,mm,1,S{wks[q]},2026-11-02T08:00:00"
        for q in range(m)
    ]
    report = folder / name
    report.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return model, report
