"""Issue 37 item 17: no negative zero in ``correct --json`` (the multi-axis sample printed ``"predicted": -0.0``)
nor on the HTML page, on every cycle of the multi-axis sample."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from setupfix.cli import main

XYZ = Path(__file__).resolve().parents[2] / "sample_reports" / "two_station_xyz"


def _floats(doc: Any) -> list[float]:
    if isinstance(doc, float):
        return [doc]
    if isinstance(doc, dict):
        return [x for v in doc.values() for x in _floats(v)]
    if isinstance(doc, list):
        return [x for v in doc for x in _floats(v)]
    return []


@pytest.mark.slow
@pytest.mark.parametrize("cycle", ["cycle_01.csv", "cycle_02.csv", "cycle_03.csv"])
def test_no_negative_zero_in_json_or_html(cycle: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    page = tmp_path / "p.html"
    capsys.readouterr()
    main(["correct", "--model", str(XYZ / "model.toml"), str(XYZ / cycle), "--json", "--html", str(page)])
    doc = json.loads(capsys.readouterr().out)
    zeros = [x for x in _floats(doc) if x == 0.0]
    assert zeros and not any(math.copysign(1.0, x) < 0 for x in zeros)
    assert "-0.0000" not in page.read_text() and "−0.0000" not in page.read_text()
