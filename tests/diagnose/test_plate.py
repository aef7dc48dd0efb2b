"""The NIST plate series (a designed experiment: tool stick-out × spindle speed) with its process log."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from setupfix.diagnose import Diagnoser, select_effects
from setupfix.pipeline.diagnose import DiagnoseRequest, diagnose_reports
from setupfix.pipeline.series import load_series

from conftest import SAMPLES

PLATE = SAMPLES / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif"
MODEL = Path(__file__).parents[1] / "data" / "nist_plate.toml"
LOG = Path(os.environ.get("SETUPFIX_SHARED", "/work/shared")) / "real-series" / "nist-mtc" / "plate_process.csv"

needs_log = pytest.mark.skipif(not LOG.is_file(), reason="the NIST process log lives in the shared folder")


@needs_log
def test_process_log_is_joined_by_serial_with_factor_levels_and_their_products():
    inp = load_series(MODEL, (PLATE,), process=str(LOG))
    s = inp.series
    ch = s.channels
    assert s.process_channels == ch and "endmill_rpm" in ch and "gap_prev_min" not in ch  # empty for part 1
    long = s.temperature[:, ch.index("doe_tool_length=Long")]
    assert long.tolist() == [0.0] * 9 + [1.0] * 9 + [0.0] * 2  # serials 10-18, parts in QIF order 1-20
    low = s.temperature[:, ch.index("doe_tool_length=Long & doe_speed=Low")]
    assert np.flatnonzero(low).tolist() == [15, 16, 17]
    rpm = s.temperature[:, ch.index("endmill_rpm")]
    assert rpm[4] == 6000.0 and rpm[9] == 12000.0
    assert any("gap_prev_min" in str(n) and "left out" in str(n) for n in inp.notes)


@needs_log
def test_the_designed_factors_are_named_per_cutter_not_wear_or_drift(tmp_path):
    """The stick-out is named with a coefficient per cutter (one per-register set, tested per part by the
    multi-column cluster-robust Wald test): the 4 mm holes (T5A) grow and the 9.4 mm holes (T4A) shrink with
    the long stick-out.  The channel chosen is the long stick-out on parts 11-18 (part 10, the first long one,
    ran with another tool list and sits nearer the short parts).  The stick-out × speed cells (three parts
    each) cannot carry five coefficients tested per part: not claimed; the residual drops from 0.097 to
    0.061 mm and the out-of-tolerance cells from 23 to 4.  (The walk forward still prefers EWMA here: W1, the
    distances' register, moves between parts and EWMA follows it; test_diagnose_plate.py.)"""
    out = diagnose_reports(DiagnoseRequest(MODEL, (PLATE,), process=str(LOG), augment=str(tmp_path / "aug.toml"),
                                           diagnoser=Diagnoser(walk=False)))
    d = out.diagnosis
    assert {e.kind for e in d.effects} == {"process"}
    assert {e.spec.channel for e in d.effects} == {"tools=7 15 3 4 5 1 23 & doe_tool_length=Long"}
    regs = {e.spec.register: e for e in d.effects}
    assert len(regs) >= 2 and None not in regs  # per cutter, not every tool alike
    assert regs["T5A"].estimate > 5 * regs["T5A"].stderr and regs["T4A"].estimate < -5 * regs["T4A"].stderr
    accepted = [s for s in d.selection.steps if s.accepted]
    assert len(accepted) == 1 and len(accepted[0].terms) == len(regs)  # one candidate, tested as a block
    assert not any("doe_speed" in str(s.spec.channel) for s in accepted)
    assert d.error_before.rms == pytest.approx(0.0970, abs=5e-4)
    assert d.error_after.rms < 0.065
    assert d.error_before.out_of_tolerance == 23 and d.error_after.out_of_tolerance <= 5
    doc = out.to_json()
    assert {e["kind"] for e in doc["effects"]} == {"process"}
    json.dumps(doc)
    # the augmented model carries them; read with the same log it reproduces the fit
    again = diagnose_reports(DiagnoseRequest(tmp_path / "aug.toml", (PLATE,), process=str(LOG),
                                             diagnoser=Diagnoser(walk=False)))
    assert [e.target for e in again.input.model.effects.effects] == [e.target for e in d.effects]
    assert again.diagnosis.error_before.rms == pytest.approx(d.error_after.rms, rel=1e-6)


@needs_log
def test_a_model_with_process_effects_needs_the_log(tmp_path):
    diagnose_reports(DiagnoseRequest(MODEL, (PLATE,), process=str(LOG), augment=str(tmp_path / "aug.toml"),
                                     diagnoser=Diagnoser(walk=False)))
    from setupfix.errors import MatchError

    with pytest.raises(MatchError, match="needs process channel"):
        load_series(tmp_path / "aug.toml", (PLATE,))


def test_without_the_log_no_wear_or_drift_is_claimed():
    d = diagnose_reports(DiagnoseRequest(MODEL, (PLATE,), diagnoser=Diagnoser(walk=False))).diagnosis
    assert not {"wear", "drift"} & {e.kind for e in d.effects}


@needs_log
def test_cli_process_option_json_and_a_bad_log(tmp_path, capsys):
    from setupfix.cli import main

    code = main(["diagnose", "--model", str(MODEL), "--process", str(LOG), "--no-walk", "--json", str(PLATE)])
    out, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(out)
    e = next(e for e in doc["effects"] if e["kind"] == "process")
    assert "doe_tool_length=Long" in e["channel"] and e["register"] in {"T1", "T5A", "T5B", "T4A", "T4B"}
    assert {"kind", "target", "estimate", "stderr", "unit", "rms_after"} <= e.keys()
    bad = tmp_path / "bad.csv"
    bad.write_text("serial,rpm\n1,9000\n1,6000\n", encoding="utf-8")
    code = main(["diagnose", "--model", str(MODEL), "--process", str(bad), "--no-walk", str(PLATE)])
    out, err = capsys.readouterr()
    assert code != 0 and "bad.csv" in err and "serial 1 appears twice" in err and "Traceback" not in err


@needs_log
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_shuffled_machining_times_give_no_time_effect(seed):
    """The plate's machining times dealt to the parts at random (without the log's channels): whatever the
    parts differ by no longer follows time, so no drift, thermal, wear or level may be named
    (``bench/diagnose_real.py``: 0 of 100 shuffles); in machining order a level at part 10 (the first long
    stick-out) is what the times alone support."""
    import dataclasses

    inp = load_series(MODEL, (PLATE,), process=str(LOG))
    s = dataclasses.replace(inp.series, temperature=inp.series.temperature[:, :0], channels=(), process_channels=())
    in_order = select_effects(inp.layout, s).found
    assert [(e.kind, e.register, str(e.cycle).rsplit(":", 1)[1]) for e in in_order] == [("level", "T4A", "10")]
    perm = np.random.default_rng(seed).permutation(s.n_cycles)
    found = select_effects(inp.layout, dataclasses.replace(s, time=s.time[perm])).found
    assert not [e for e in found if e.kind in ("drift", "thermal", "wear", "level")]


@needs_log
def test_the_tui_diagnosis_takes_the_process_log():
    """``setupfix tui --process LOG``: the history panel's diagnosis (its worker, through the use case) joins
    the log per part and names the process effects, as ``diagnose --process`` does."""
    from setupfix.tui import workers

    with_log = workers.diagnose(MODEL, PLATE, LOG)
    without = workers.diagnose(MODEL, PLATE)
    assert {e.kind for e in with_log.effects} == {"process"}
    assert "process" not in {e.kind for e in without.effects}
    assert with_log.after[0] < without.after[0]
    from setupfix.cli import build_parser

    args = build_parser().parse_args(["tui", "--model", str(MODEL), "--process", str(LOG), str(PLATE)])
    assert args.process == LOG
