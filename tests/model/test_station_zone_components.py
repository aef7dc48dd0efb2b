"""A templated zone whose components are "{station} …" names,
also dimensions of their own, fed by a combined report naming "S1 Hole 1 X" (the held-out style)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from setupfix.model import load_model
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest

HERE = Path(__file__).resolve().parent / "data"
DEV = {"S1": (0.025, 0.035), "S2": (-0.010, 0.010)}


def test_templated_zone_components_name_the_station() -> None:
    model = load_model(HERE / "station_zone.toml")
    zones = {d.id: d.components for d in model.dimensions if d.zone}
    assert zones == {"S1H1P": ("S1 Hole 1 X", "S1 Hole 1 Y"), "S2H1P": ("S2 Hole 1 X", "S2 Hole 1 Y")}
    (cycle,) = correct_report(CorrectRequest(model), HERE / "station_zone.csv").cycles
    assert not cycle.part.absent and not cycle.part.unmatched
    doc = cycle_json(cycle)
    rows = {r["id"]: r for r in doc["dimensions"]}
    for station, wks in (("S1", "W1"), ("S2", "W2")):
        dx, dy = DEV[station]
        tx, ty = doc["corrections"][f"{wks}.X"], doc["corrections"][f"{wks}.Y"]
        assert rows[f"{station}H1P"]["predicted"] == pytest.approx(math.hypot(dx + tx, dy + ty), abs=1e-9)
        assert rows[f"{station}H1X"]["predicted"] == pytest.approx(dx + tx, abs=1e-9)
    assert doc["margin_after"] == pytest.approx(min(r["margin"] for r in doc["dimensions"]), abs=1e-9)
