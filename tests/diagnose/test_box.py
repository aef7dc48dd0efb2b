"""The real NIST MTC box series as a regression case: silence where there is no effect (issue 24).

19 boxes, no corrections applied, the machining log gives times and spindle minutes but no
designed factor.  The CMM measured the boxes in another order than they were cut: with the log
the parts are put in machining order by serial.  Nothing is found with or without the log, the
walk forward recommends from the declared model, and shuffling the parts' times finds nothing
either (``bench/diagnose_real.py``: 0 of 100 shuffles).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from setupfix.diagnose import select_effects
from setupfix.inputs.series import load_series
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports

SHARED = Path(os.environ.get("SETUPFIX_SHARED", "/work/shared"))
BOX = SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Box_Results_19parts.qif"
LOG = SHARED / "real-series" / "nist-mtc" / "box_process.csv"
MODEL = Path(__file__).parent / "data" / "nist_box.toml"

pytestmark = pytest.mark.skipif(not (BOX.is_file() and LOG.is_file()), reason="the NIST box lives in the shared folder")


def test_the_box_is_put_in_machining_order_by_its_log() -> None:
    inp = load_series(MODEL, (BOX,), process=str(LOG))
    s = inp.series
    assert s.n_cycles == 19 and s.origin.startswith("2017-02-02T18:48:03")
    assert np.all(np.diff(s.time) > 0)
    assert [c.rsplit(":", 1)[1] for c in s.cycles] == [str(k) for k in range(2, 21)]  # serials in cutting order
    assert any("machining time is the process log's timestamp" in str(n) for n in inp.notes)


@pytest.mark.parametrize("with_log", [False, True])
def test_nothing_is_found_on_the_box(with_log: bool) -> None:
    out = diagnose_reports(DiagnoseRequest(MODEL, (BOX,), process=str(LOG) if with_log else None))
    d = out.diagnosis
    assert d.effects == ()
    assert d.next_from.source == "declared"
    assert d.error_after.rms == d.error_before.rms


def test_shuffled_times_give_no_time_effect_on_the_box() -> None:
    inp = load_series(MODEL, (BOX,), process=str(LOG))
    s = dataclasses.replace(inp.series, temperature=inp.series.temperature[:, :0], channels=(), process_channels=())
    for seed in range(3):
        perm = np.random.default_rng(seed).permutation(s.n_cycles)
        assert select_effects(inp.layout, dataclasses.replace(s, time=s.time[perm])).found == ()
