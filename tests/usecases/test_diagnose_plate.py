"""The real NIST MTC plate series as a regression case of the diagnosis's next correction (issue 24).

The plate is a designed experiment (stick-out × spindle speed), its last two parts cut back at the operator's
setting: the 4–5 mm holes (T5A, T5B), the 3 mm holes (T1) and the 10 mm holes (T4B) sat in the middle of their
tolerances there (model: tests/data/nist_plate.toml, the one plate model).  The
effect the series suggests does not beat EWMA on later parts, and the report must say so; and no register whose
holes were centred on the last two parts may be moved.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES

from setupfix.diagnose import Diagnoser
from setupfix.inputs.series import load_series
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports, recommend_next

PLATE = SAMPLES / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif"
MODEL = Path(__file__).parents[1] / "data" / "nist_plate.toml"
PROCESS = Path(os.environ.get("SETUPFIX_SHARED", "/work/shared")) / "real-series" / "nist-mtc" / "plate_process.csv"


def _centred_by_hand(model_path: Path, deviation: np.ndarray, fraction: float = 0.25) -> set[str]:
    """Registers every dimension of which sat within ``fraction`` half tolerances of the centre on both of the
    last two parts (no corrections were applied during the series: the parts are at the registers as they are)."""
    inp = load_series(model_path, (PLATE,))
    lay = inp.layout
    centre, half = (lay.upper + lay.lower) / 2, (lay.upper - lay.lower) / 2
    near = np.all(np.abs(deviation[-2:] - centre) <= fraction * half, axis=0)
    return {r for i, r in enumerate(lay.register_ids) if np.all(near[lay.composite[i] != 0])}


def test_plate_report_says_the_effect_did_not_beat_ewma_and_keeps_centred_holes() -> None:
    out = diagnose_reports(DiagnoseRequest(MODEL, (PLATE,)))
    doc = out.to_json()
    wf = doc["walk_forward"]
    assert doc["effects"], "the series suggests an effect"
    assert wf["augmented"]["centre_rms"] > wf["ewma"]["centre_rms"]
    assert doc["next_from"] == "ewma" and "did not beat ewma" in doc["next_from_reason"]
    assert any("did not beat ewma" in n for n in doc["notes"])
    centred = _centred_by_hand(MODEL, out.diagnosis.series.deviation)
    assert centred == {"T1", "T5A", "T5B", "T4B"}  # the 3 mm, the 4–5 mm and the 10 mm holes
    assert set(doc["held_centred"]) == centred
    assert all(doc["next_correction"].get(r, 0.0) == 0.0 for r in centred)
    assert any(doc["next_correction"].get(r, 0.0) != 0.0 for r in ("W1", "T4A"))  # what is off-centre moves


@pytest.mark.skipif(not PROCESS.is_file(), reason="needs ../shared/real-series")
def test_plate_with_its_machining_times() -> None:
    """With the parts' machining times from the process log the verdict stands."""
    inp = load_series(MODEL, (PLATE,))
    log = pd.read_csv(PROCESS)
    stamps = pd.to_datetime(log["timestamp"])
    hours = np.asarray((stamps - stamps.iloc[0]).dt.total_seconds() / 3600, dtype=np.float64)
    series = dataclasses.replace(inp.series, time=hours, origin=str(log["timestamp"].iloc[0]))
    d = Diagnoser().run(inp.layout, series)
    assert d.next_from.source == "ewma"
    assert d.walk is not None
    b = d.walk.budgets
    assert b["augmented"].centre_rms > b["ewma"].centre_rms
    cycle, _ = recommend_next(inp.model, d)
    assert cycle is not None
    for r in _centred_by_hand(MODEL, series.deviation):
        assert cycle.corrections.get(r, 0.0) == 0.0
