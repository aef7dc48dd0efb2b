"""What the text doors show for a stopped solve (issue 37 #14) and for a value that rounds to zero (#17).

* a correction from a solve the work limit stopped is labelled ``APPLY (STOPPED: …)`` with the
  stage, in the verdict line and in the TUI's summary, never a plain APPLY;
* no number is ever printed as ``-0.0000`` (the multi-axis sample's predicted values printed it).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import SAMPLES

from setupfix.cli import main
from setupfix.correction.numbers import fmt
from setupfix.correction.safety import RuleEffect
from setupfix.model import load_model
from setupfix.optimize import Stopped
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection
from setupfix.views.correction import signed, summary
from setupfix.views.present import format_correction, format_number, verdict_label, verdict_line

XYZ = SAMPLES / "two_station_xyz"
NEGATIVE_ZERO = re.compile(r"-0\.0+(?![0-9])")


def stopped_cycle(stage: str = "leximin") -> CycleCorrection:
    """The guide-pins cycle 02 as a solve stopped by the work limit in ``stage`` would leave it."""
    request = CorrectRequest(load_model(SAMPLES / "guide_pins" / "model.toml"))
    (cycle,) = correct_report(request, SAMPLES / "guide_pins" / "cycle_02.csv").cycles
    assert cycle.verdict == "apply"
    rec = cycle.recommendation
    stopped = Stopped(stage, "work limit")
    message = f"solve stopped by the work limit (the {stage} stage stopped): the levels reached"
    rec = dataclasses.replace(
        rec,
        result=dataclasses.replace(rec.result, status="time_limit", stopped=stopped),
        rules=(*rec.rules, RuleEffect("stopped", message)),
    )
    result = dataclasses.replace(cycle.result, status="time_limit", stopped=stopped)
    return dataclasses.replace(cycle, recommendation=rec, result=result)


def test_a_stopped_apply_is_labelled_with_its_stage_at_every_text_door() -> None:
    cycle = stopped_cycle("grid optimum")
    assert verdict_label(cycle) == "APPLY (STOPPED: work limit in the grid optimum stage)"
    assert "solve stopped by the work limit (the grid optimum stage stopped)" in verdict_line(cycle)
    assert "verdict: APPLY (STOPPED: work limit in the grid optimum stage)" in format_correction(cycle)
    head = summary(cycle)  # what the TUI shows
    assert head.stopped == "work limit in the grid optimum stage" and head.solved and head.verdict == "apply"


def test_a_proved_apply_has_no_stopped_mark() -> None:
    request = CorrectRequest(load_model(SAMPLES / "guide_pins" / "model.toml"))
    (cycle,) = correct_report(request, SAMPLES / "guide_pins" / "cycle_03.csv").cycles
    assert verdict_label(cycle) == cycle.verdict.upper() and summary(cycle).stopped == ""


@pytest.mark.parametrize("value", [-0.0, -1e-17, -4.9e-5, -0.00004999, 1e-300, -1e-300])
def test_a_value_that_rounds_to_zero_prints_without_a_sign_of_its_own(value: float) -> None:
    assert fmt(value, 4) == "0.0000" and fmt(value, 4, sign=True) == "+0.0000"
    assert format_number(value) == "+0.0000" and signed(value) == "+0.0000"


def test_fmt_agrees_with_rounding_and_never_prints_negative_zero() -> None:
    rng = np.random.default_rng(7)
    values = np.r_[rng.normal(0, 1e-4, 20_000), rng.normal(0, 1.0, 2_000), -np.logspace(-12, -3, 200)]
    for v in values:
        for digits in (3, 4):
            text = fmt(float(v), digits, sign=True)
            assert not NEGATIVE_ZERO.fullmatch(text), (v, text)
            assert float(text) == pytest.approx(round(float(v), digits), abs=10.0**-digits / 10)
    assert fmt(math.nan) == fmt(None) == fmt(math.inf) == "—"


def _correct_text(report: Path, *extra: str) -> str:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["correct", "--model", str(XYZ / "model.toml"), str(report), *extra])
    assert code == 0, err.getvalue()
    return out.getvalue()


def _shifted(tmp_path: Path, source: Path, shift: float) -> Path:
    """A variant of ``source``: every measured value shifted by ``shift``."""
    with source.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    columns = [k for k in rows[0] if k.lower() in ("actual", "deviation")]
    assert columns
    for row in rows:
        for k in columns:
            row[k] = f"{float(row[k]) + shift:.4f}"
    target = tmp_path / f"shifted_{source.name}"
    with target.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return target


@pytest.mark.parametrize("cycle", ["cycle_01.csv", "cycle_03.csv"])
def test_the_multi_axis_sample_prints_no_negative_zero(tmp_path: Path, cycle: str) -> None:
    for report in (XYZ / cycle, _shifted(tmp_path, XYZ / cycle, 0.0002)):
        text = _correct_text(report)
        assert "+0.0000" in text  # a predicted value at zero is shown, with the plus sign
        assert not NEGATIVE_ZERO.search(text), [line for line in text.splitlines() if NEGATIVE_ZERO.search(line)]
