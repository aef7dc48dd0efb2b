"""Position zones in a report's terms (issue 39): a CMM prints a position as the diameter 2‖δ‖,
so every door gives it beside the radial margin; and the bundled two-station fixture with its zone
components also toleranced as dimensions of their own (the held-out style) loads and solves."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from setupfix.correction.zones import cmm_position
from setupfix.model import load_model
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection
from setupfix.views.correction import dimension_rows as screen_rows
from setupfix.views.html import correction_page
from setupfix.views.present import format_correction

SAMPLE = Path(__file__).resolve().parents[2] / "sample_reports" / "two_station_xyz"
CYCLES = sorted(SAMPLE.glob("cycle_*.csv"))


def report_deviation(report: Path, name: str) -> float:
    """A characteristic's deviation straight from the CSV (actual − nominal)."""
    table = pd.read_csv(report)
    row = table[table["characteristic"] == name].iloc[0]
    return float(row["actual"] - row["nominal"])


def corrected(model_path: Path, report: Path) -> CycleCorrection:
    (cycle,) = correct_report(CorrectRequest(load_model(model_path)), report).cycles
    return cycle


def test_cmm_position_is_the_diameter() -> None:
    assert cmm_position(np.array([0.0, 0.0482, 0.05])).tolist() == pytest.approx([0.0, 0.0964, 0.1])


@pytest.mark.parametrize("report", CYCLES, ids=lambda p: p.stem)
def test_every_zone_row_gives_the_diameter_a_cmm_prints(report: Path) -> None:
    cycle = corrected(SAMPLE / "model.toml", report)
    doc = cycle_json(cycle)
    zones = {d.name: d for d in cycle.model.dimensions if d.zone}
    rows = [r for r in doc["dimensions"] if r["name"] in zones]
    assert rows
    for row in rows:
        dim = zones[row["name"]]
        assert dim.diameter is not None
        dx, dy = (report_deviation(report, c) for c in dim.components)
        assert row["zone_position"] == pytest.approx(2 * math.hypot(dx, dy), abs=2e-9)
        assert row["zone_position_predicted"] == pytest.approx(2 * row["predicted"], abs=2e-9)
        assert row["zone_diameter"] == dim.diameter
        assert row["margin"] == pytest.approx(dim.diameter / 2 - row["predicted"], abs=2e-9)  # still radial
    others = [r for r in doc["dimensions"] if r["name"] not in zones]
    assert others and not any("zone_position" in r for r in others)
    text = format_correction(cycle)
    page = correction_page(cycle)
    for row in rows:
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(row["name"] + " ") and "⌀" in ln)
        assert f"measured ⌀{row['zone_position']:.4f}" in line
        assert f"tolerance ⌀{row['zone_diameter']:.4f}" in line
        assert f"<td>{row['zone_position']:.4f}</td>" in page


COMPONENT_DIMENSIONS = """
[dimensions.P1D7X]
name = "P1 Hole 1 X"
group = "P1"
features = { P1_HOLE1 = 1 }
axis = "X"
nominal = 0.0
lower = -0.03
upper = 0.03

[dimensions.P2D7Y]
name = "P2 Hole 1 Y"
group = "P2"
features = { P2_HOLE1 = 1 }
axis = "Y"
nominal = 0.0
lower = -0.02
upper = 0.02
"""


@pytest.mark.parametrize("report", CYCLES, ids=lambda p: p.stem)
def test_zone_components_that_are_dimensions_load_and_solve(tmp_path: Path, report: Path) -> None:
    """The held-out style: "P1 Hole 1 X" is a component of the zone P1D7 and a dimension of its own.
    One report row feeds both; every prediction is recomputed here from the corrections with the
    spec's displacement p = t + θ (π/180) (s × x) of a feature at x = (40, 25, 0)."""
    model_path = tmp_path / "model.toml"
    model_path.write_text((SAMPLE / "model.toml").read_text() + COMPONENT_DIMENSIONS)
    cycle = corrected(model_path, report)
    assert not cycle.part.absent and not cycle.part.unmatched
    doc = cycle_json(cycle)
    rows = {r["id"]: r for r in doc["dimensions"]}
    c = doc["corrections"]
    for station, wks, zone, extra, comp in (("P1", "W1", "P1D7", "P1D7X", 0), ("P2", "W2", "P2D7", "P2D7Y", 1)):
        theta = math.radians(c[f"{wks}.C"])
        moved = (c[f"{wks}.X"] - 25.0 * theta, c[f"{wks}.Y"] + 40.0 * theta)  # s × x = (−25, 40, 0)
        dev = (report_deviation(report, f"{station} Hole 1 X"), report_deviation(report, f"{station} Hole 1 Y"))
        assert rows[extra]["deviation"] == pytest.approx(dev[comp], abs=1e-9)
        assert rows[extra]["predicted"] == pytest.approx(dev[comp] + moved[comp], abs=1e-9)
        radial = math.hypot(dev[0] + moved[0], dev[1] + moved[1])
        assert rows[zone]["predicted"] == pytest.approx(radial, abs=1e-9)
        assert rows[zone]["zone_position_predicted"] == pytest.approx(2 * radial, abs=2e-9)
        assert rows[zone]["margin"] == pytest.approx(0.05 - radial, abs=1e-9)
    margins = [r["margin"] for r in doc["dimensions"]]
    assert doc["margin_after"] == pytest.approx(min(margins), abs=1e-9)


def test_the_screen_rows_carry_the_cmm_diameter() -> None:
    cycle = corrected(SAMPLE / "model.toml", CYCLES[0])
    rows = {r.id: r for r in screen_rows(cycle)}
    for d in cycle.model.dimensions:
        if d.id not in rows:
            continue
        row = rows[d.id]
        if d.zone:
            assert row.zone is not None and row.zone[0] == pytest.approx(2 * row.deviation, abs=2e-9)
            assert row.position_text == (f"⌀{2 * row.deviation:.3f} → ⌀{2 * row.predicted:.3f} of ⌀{d.diameter:.3f}")
        else:
            assert row.zone is None and row.position_text == ""
