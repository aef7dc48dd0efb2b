"""A draft model (``[process] draft = true``) never yields APPLY: every door holds with the rule ``draft``."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.model import load_model
from setupfix.tui.session import open_report
from setupfix.usecases.batch import run_batch
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest
from setupfix.views.correction import summary as headline


def draft_copy(tmp_path: Path) -> Path:
    """The guide-pins model (which recommends APPLY on cycle 1) with ``draft = true`` added."""
    text = (GUIDE_PINS / "model.toml").read_text(encoding="utf-8")
    head, sep, rest = text.partition("[process]\n")
    assert sep
    path = tmp_path / "draft.toml"
    path.write_text(head + sep + "draft = true\n" + rest, encoding="utf-8")
    return path


def test_the_same_model_applies_and_its_draft_holds_with_every_change_zero(tmp_path: Path) -> None:
    report = GUIDE_PINS / "cycle_01.csv"
    (done,) = correct_report(CorrectRequest(load_model(GUIDE_PINS / "model.toml")), report).cycles
    assert done.verdict == "apply" and np.any(done.recommendation.x)  # so the hold below is the draft's
    path = draft_copy(tmp_path)
    model = load_model(path)
    assert model.draft
    (held,) = correct_report(CorrectRequest(model), report).cycles
    rec = held.recommendation
    assert held.verdict == "hold" and rec.solved and not np.any(rec.x) and not np.any(held.result.x)
    assert [r.rule for r in rec.rules] == ["draft"]
    message = rec.rules[0].message
    assert message.startswith("edit the model (draft)") and str(path) in message and "draft = true" in message
    assert rec.alarm.startswith("DRAFT MODEL: edit the model (draft)")
    assert held.result.message.startswith("hold: edit the model (draft)")
    assert all(v == 0 for v in held.corrections.values())


def test_a_draft_holds_through_the_cli_json_with_exit_status_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from setupfix.cli import main

    path = draft_copy(tmp_path)
    code = main(["correct", "--model", str(path), "--json", str(GUIDE_PINS / "cycle_01.csv")])
    captured = capsys.readouterr()
    obj = json.loads(captured.out)
    assert code == 0 and obj["verdict"] == "hold" and set(obj["corrections"].values()) == {0.0}
    assert [r["rule"] for r in obj["rules"]] == ["draft"] and str(path) in obj["rules"][0]["message"]
    assert "DRAFT MODEL" in captured.err
    assert main(["correct", "--model", str(path), str(GUIDE_PINS / "cycle_01.csv")]) == 0
    assert "verdict: HOLD — DRAFT MODEL: edit the model (draft)" in capsys.readouterr().out


def test_batch_and_the_tui_session_hold_a_draft_too(tmp_path: Path) -> None:
    model = load_model(draft_copy(tmp_path))
    folder = tmp_path / "reports"
    folder.mkdir()
    for i in (1, 2):
        shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", folder / f"cycle_0{i}.csv")
    summary = run_batch(CorrectRequest(model), folder, tmp_path / "offsets.csv", settle=0)
    assert summary.parts == 2 and summary.verdicts["hold"] == 2 and not summary.verdicts["apply"]
    opened = open_report(CorrectRequest(model), GUIDE_PINS / "cycle_02.csv")
    assert [c.verdict for c in opened.corrections] == ["hold"]
    assert [r.rule for r in opened.corrections[0].recommendation.rules] == ["draft"]
    shown = headline(opened.corrections[0])  # what the TUI's headline shows
    assert shown.verdict == "hold" and shown.alarm.startswith("DRAFT MODEL: edit the model (draft)")
    assert shown.rules[0].startswith("draft: edit the model (draft)")


def test_removing_the_key_recommends_again(tmp_path: Path) -> None:
    model = load_model(draft_copy(tmp_path))
    (cycle,) = correct_report(
        CorrectRequest(dataclasses.replace(model, draft=False)), GUIDE_PINS / "cycle_01.csv"
    ).cycles
    assert cycle.verdict == "apply"


def test_a_batch_with_a_store_leaves_a_drafts_reports_unprocessed(tmp_path: Path) -> None:
    from setupfix.store import open_store

    model = load_model(draft_copy(tmp_path))
    folder = tmp_path / "reports"
    folder.mkdir()
    shutil.copy(GUIDE_PINS / "cycle_01.csv", folder / "cycle_01.csv")
    with open_store(tmp_path / "h.db") as store:
        held = run_batch(CorrectRequest(model), folder, tmp_path / "held.csv", settle=0, store=store)
        assert held.verdicts["hold"] == 1
        # the user edits the model (removes the key): the next run corrects the report, it is not "already processed"
        edited = run_batch(
            CorrectRequest(dataclasses.replace(model, draft=False)), folder, tmp_path / "o.csv", settle=0, store=store
        )
        assert edited.verdicts["apply"] == 1 and not edited.skipped
        again = run_batch(
            CorrectRequest(dataclasses.replace(model, draft=False)), folder, tmp_path / "o2.csv", settle=0, store=store
        )
        assert again.parts == 0 and len(again.skipped) == 1  # processed now: skipped as before
