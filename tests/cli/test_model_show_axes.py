"""``model show`` names the axes a multi-axis model has (issue 37 item 17), not "(axis Z …)"."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from setupfix.cli import main

ROOT = Path(__file__).resolve().parents[2]
XYZ = ROOT / "sample_reports" / "two_station_xyz" / "model.toml"


def show(capsys: pytest.CaptureFixture[str], model: Path, *extra: str) -> str:
    assert main(["model", "show", *extra, str(model)]) == 0
    return capsys.readouterr().out


def test_the_sample_shows_its_axes_rotation_and_radius(capsys: pytest.CaptureFixture[str]) -> None:
    head = show(capsys, XYZ).splitlines()[0]
    assert "(axes X, Y, Z, spindle Z, rotation C (W1, W2), tool radius, unit mm" in head
    assert "(axis Z" not in head
    doc = json.loads(show(capsys, XYZ, "--json"))
    assert doc["axes"] == ["X", "Y", "Z"] and doc["spindle"] == "Z"


def test_a_variant_without_rotation_or_radius(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = XYZ.read_text(encoding="utf-8").replace('axes = ["X", "Y", "Z"]', 'axes = ["X", "Y", "Z"]\n', 1)
    text = text.replace("rotation = true", "rotation = false", 1).replace('radius = "D1"\nradius_limit = 0.05\n', "")
    text = "\n".join(li for li in text.splitlines() if not li.startswith("radius = {"))
    model = tmp_path / "model.toml"
    model.write_text(text, encoding="utf-8")
    head = show(capsys, model).splitlines()[0]
    assert "(axes X, Y, Z, spindle Z, unit mm" in head and "rotation" not in head.split("(")[-1]


def test_a_one_axis_model_still_shows_its_axis(capsys: pytest.CaptureFixture[str]) -> None:
    head = show(capsys, ROOT / "sample_reports" / "guide_pins" / "model.toml").splitlines()[0]
    assert head.endswith("(axis Z, unit mm, resolution 0.001)")
    assert "axes" not in json.loads(show(capsys, ROOT / "sample_reports" / "guide_pins" / "model.toml", "--json"))
