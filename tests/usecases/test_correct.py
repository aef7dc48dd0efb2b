"""Pipeline "correct": stations of a multi-part report merged into one fixture cycle."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import pytest

from setupfix.core.errors import MatchError
from setupfix.model import ProcessModel, load_model, model_from_dict
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, CycleOptions


def correct(
    model: ProcessModel, path: Path, stations: Sequence[str] | Mapping[str, str] | None = None
) -> tuple[CycleCorrection, ...]:
    return correct_report(CorrectRequest(model, cycles=CycleOptions.of(stations)), path).cycles


MODEL = {
    "process": {"name": "two stations", "resolution": 0.001, "limit": 0.1},
    "wks": {"W1": {"register": "G54"}, "W2": {"register": "G55"}},
    "tools": {"T1": {"register": "H1"}},
    "features": {"F1": {"wks": {"W1": 1}, "tools": {"T1": 1}}, "F2": {"wks": {"W2": 1}, "tools": {"T1": 1}}},
    "dimensions": {
        "A": {"name": "Depth", "group": "P1", "features": {"F1": 1}, "nominal": 10, "lower": -0.05, "upper": 0.05},
        "B": {"name": "Depth", "group": "P2", "features": {"F2": 1}, "nominal": 10, "lower": -0.05, "upper": 0.05},
    },
}


def report(tmp_path: Path, parts: tuple[str, str] = ("s1", "s2")) -> Path:
    path = tmp_path / "r.csv"
    path.write_text(
        f"characteristic,nominal,actual,part\nDepth,10,10.040,{parts[0]}\nDepth,10,9.990,{parts[1]}\n", encoding="utf-8"
    )
    return path


def test_repeated_names_without_stations_are_refused(tmp_path: Path) -> None:
    model = model_from_dict(MODEL)
    with pytest.raises(MatchError, match="names several dimensions"):
        correct(model, report(tmp_path))


def test_stations_in_order_make_one_cycle(tmp_path: Path) -> None:
    model = model_from_dict(MODEL)
    (pc,) = correct(model, report(tmp_path), stations=["P2", "P1"])
    assert pc.part.deviation.tolist() == pytest.approx([-0.010, 0.040])  # s2 → P2 (B), s1 → P1 (A)
    # both stations centred: W1 − W2 = -0.05 spread; the optimum centres each through its own WKS
    assert pc.result.margin_after == pytest.approx(0.05, abs=1e-9)
    assert pc.corrections["W1"] + pc.corrections["T1"] == pytest.approx(0.010)
    assert pc.corrections["W2"] + pc.corrections["T1"] == pytest.approx(-0.040)


def test_part_names_equal_to_groups_are_stations(tmp_path: Path) -> None:
    model = model_from_dict(MODEL)
    (pc,) = correct(model, report(tmp_path, parts=("P1", "p2")))
    assert pc.part.deviation.tolist() == pytest.approx([0.040, -0.010])


def test_unknown_station_and_wrong_count(tmp_path: Path) -> None:
    model = model_from_dict(MODEL)
    with pytest.raises(MatchError, match="station 'P9'"):
        correct(model, report(tmp_path), stations={"s1": "P1", "s2": "P9"})
    with pytest.raises(MatchError, match="3 stations given for 2 parts"):
        correct(model, report(tmp_path), stations=["P1", "P2", "P1"])


def test_readme_headline_example() -> None:
    """README: P1 D6 and P1 D7 move alike (−W5 − T5) and were measured 0.0352 mm apart, so no
    correction beats the LP bound 0.1 − 0.0352/2, and they are the binding pair."""
    from conftest import GUIDE_PINS

    (pc,) = correct(load_model(GUIDE_PINS / "model.toml"), GUIDE_PINS / "cycle_01.csv")
    dev = {r["name"]: r["deviation"] for r in pc.dimension_rows()}
    spread = dev["P1 D6"] - dev["P1 D7"]
    assert spread == pytest.approx(0.0352, abs=5e-5)
    out = cycle_json(pc)
    assert out["bound"] == pytest.approx(0.1 - spread / 2, abs=1e-9)
    assert set(out["binding"]) == {"P1 D6", "P1 D7"}
    assert out["margin_after"] == pytest.approx(0.0822, abs=5e-5) and out["verdict"] == "apply"
