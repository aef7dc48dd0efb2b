"""The bundled closed-loop samples say what their READMEs say."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import GUIDE_PINS, SAMPLES

from setupfix.diagnose import Diagnoser
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports

LOOP = SAMPLES / "closed_loop"


@pytest.mark.slow
def test_simulated_series_reveals_its_undeclared_thermal_effect() -> None:
    out = diagnose_reports(
        DiagnoseRequest(
            GUIDE_PINS / "model.toml",
            (LOOP / "measurements.csv",),
            corrections=str(LOOP / "corrections.csv"),
            temperatures=str(LOOP / "temperatures.csv"),
            diagnoser=Diagnoser(walk=False),
        )
    )
    truth = json.loads((LOOP / "truth.json").read_text())["hidden_effects"]
    found = [(e.kind, e.target) for e in out.diagnosis.effects]
    assert found == [(t["kind"], t["target"]) for t in truth]
    e = out.diagnosis.effects[0]
    assert abs(e.estimate - truth[0]["magnitude"]) < 3 * e.stderr
    assert out.diagnosis.error_after.rms < 0.0021 < 0.006 < out.diagnosis.error_before.rms


def test_real_sheet_metal_offset_only_model_leaves_a_tilt() -> None:
    """Six real parts: the 17 points keep their own form errors (lack of fit), so at the default
    α = 0.01 no tilt is claimed; at α = 0.05 the position effects in x and z are."""
    report = SAMPLES / "qif" / "QIF3_SheetMetal_Results_6_samples.QIF"
    model = LOOP / "sheet_metal" / "model.toml"
    strict = diagnose_reports(DiagnoseRequest(model, (report,), diagnoser=Diagnoser(walk=False))).diagnosis
    assert strict.effects == () and strict.selection.lack_of_fit
    d = diagnose_reports(DiagnoseRequest(model, (report,), diagnoser=Diagnoser(walk=False, alpha=0.05))).diagnosis
    assert [(e.kind, e.target) for e in d.effects] == [("position", "x"), ("position", "z")]
    assert d.error_after.out_of_tolerance < d.error_before.out_of_tolerance
    assert d.error_after.rms < 0.7 * d.error_before.rms


def test_positions_from_the_reports_when_the_model_has_none(tmp_path: Path) -> None:
    text = (LOOP / "sheet_metal" / "model.toml").read_text(encoding="utf-8")
    bare = tmp_path / "model.toml"
    bare.write_text("\n".join(line for line in text.splitlines() if not line.startswith("position")), encoding="utf-8")
    report = SAMPLES / "qif" / "QIF3_SheetMetal_Results_6_samples.QIF"
    out = diagnose_reports(DiagnoseRequest(bare, (report,), diagnoser=Diagnoser(walk=False, alpha=0.05)))
    assert [(e.kind, e.target) for e in out.diagnosis.effects] == [("position", "x"), ("position", "z")]
    assert any("taken from the reports' x, y, z" in str(n) for n in out.notes)
