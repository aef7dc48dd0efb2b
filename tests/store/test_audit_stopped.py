"""Issue 37 item 14 in the store: the audit's verdict column of a stopped solve is never a plain verdict.

The result JSON is ``correct --json``'s own (a guard that fires at ``--time-limit 1e-9``), and variants of it:
a stopped apply, a proved solve, a result from before the ``stopped`` key existed."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from setupfix.cli import main
from setupfix.store.audit import audit_of

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


def _correct(capsys: pytest.CaptureFixture[str], *extra: str) -> dict[str, Any]:
    capsys.readouterr()
    main(["correct", "--model", str(GUIDE / "model.toml"), str(GUIDE / "cycle_02.csv"), "--json", *extra])
    doc: dict[str, Any] = json.loads(capsys.readouterr().out)
    return doc


def test_a_guard_stop_is_stored_as_not_solved_with_its_stage(capsys: pytest.CaptureFixture[str]) -> None:
    result = _correct(capsys, "--time-limit", "1e-9")
    assert result["verdict"] == "hold" and result["solved"] is False
    stage = result["stopped"]["stage"]
    assert audit_of({}, result).verdict == f"not solved (time limit in the {stage} stage)"


def test_a_stopped_apply_and_a_proved_one(capsys: pytest.CaptureFixture[str]) -> None:
    proved = _correct(capsys)
    assert proved["stopped"] is None and audit_of({}, proved).verdict == proved["verdict"] == "apply"
    stopped = {**proved, "status": "time_limit", "stopped": {"stage": "leximin", "reason": "work limit"}}
    assert audit_of({}, stopped).verdict == "apply (stopped: work limit in the leximin stage)"
    older = {k: v for k, v in proved.items() if k not in ("stopped", "solved")}  # stored before the keys
    assert audit_of({}, older).verdict == "apply"
