"""Issue 37 item 10 in ``diagnose``: an unmatched report name gets the same "did you mean" as ``correct``
(:func:`setupfix.model.measurements.did_you_mean`), in the series' note."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from setupfix.cli import main

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


@pytest.mark.parametrize(("wrong", "meant"), [("P1-D4", "P1 D4"), ("p3_d2", "P3 D2")])
def test_diagnose_suggests_the_absent_dimension_an_unmatched_name_means(
    wrong: str, meant: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for i in range(2, 6):
        text = (GUIDE / f"cycle_0{i}.csv").read_text()
        if i == 5:
            assert f"\n{meant}," in text
            text = text.replace(f"\n{meant},", f"\n{wrong},")
        (tmp_path / f"cycle_0{i}.csv").write_text(text)
    capsys.readouterr()
    assert main(["diagnose", "--model", str(GUIDE / "model.toml"), str(tmp_path), "--no-walk", "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert any(f"{wrong} (did you mean {meant!r}?)" in n for n in notes), notes
