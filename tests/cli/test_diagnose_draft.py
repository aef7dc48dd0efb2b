"""Issue 37 item 2: a draft model in ``diagnose`` says it is a draft, and gives no next correction.

The issue: "next correction: none" with every register at 0 and no word of the draft.  Variants: the
guide pins' model marked ``draft = true`` over a folder (text and JSON), and a scaffold ``model init``
wrote from the PC-DMIS reports (a real draft) over a history store.  The draft is stated as ``correct``
states it (its alarm, :func:`setupfix.views.present.verdict_line`), with the same exit status.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from setupfix.cli import main

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
PCDMIS = ROOT / "sample_reports" / "pcdmis"


def draft_of(tmp_path: Path) -> Path:
    text = (GUIDE / "model.toml").read_text()
    model = tmp_path / "draft.toml"
    model.write_text(text.replace("[process]\n", "[process]\ndraft = true\n", 1))
    return model


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def next_line(out: str) -> str:
    (line,) = [x for x in out.splitlines() if x.startswith("next correction:")]
    return line


def test_a_draft_model_says_so_and_gives_no_next_correction(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = draft_of(tmp_path)
    correct_code, correct_out, _ = run(capsys, "correct", "--model", str(model), str(GUIDE / "cycle_05.csv"))
    code, out, err = run(capsys, "diagnose", "--model", str(model), "--no-walk", str(GUIDE))
    assert code == correct_code == 0, err
    line = next_line(out)
    assert line.startswith("next correction: no correction, the model is a draft — DRAFT MODEL: ")
    assert f"{model} is a scaffold" in line and "remove 'draft = true'" in line
    assert "DRAFT MODEL: edit the model (draft)" in correct_out  # the same words as correct's verdict
    assert not re.search(r"[+-]\d\.\d{4}", line) and "none" not in line
    code, out, err = run(capsys, "diagnose", "--model", str(model), "--no-walk", "--json", str(GUIDE))
    assert code == 0, err
    doc = json.loads(out)
    assert doc["draft"] is True and doc["next_correction"] is None
    assert any(n.startswith("no next correction: DRAFT MODEL") for n in doc["notes"])
    # the same model without the mark: a correction, as before
    code, out, err = run(capsys, "diagnose", "--model", str(GUIDE / "model.toml"), "--no-walk", "--json", str(GUIDE))
    doc = json.loads(out)
    assert doc["draft"] is False and doc["next_correction"]["W1"] == pytest.approx(0.005)


def test_a_scaffold_over_a_store_is_a_draft_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reports = tmp_path / "reports"
    reports.mkdir()
    for name in ("bracket_two_parts.txt", "bracket_minus_negative.txt"):
        shutil.copy(PCDMIS / name, reports / name)
    model = tmp_path / "model.toml"
    code, _, err = run(capsys, "model", "init", str(reports), "--axis", "Z", "-o", str(model))
    assert code == 0, err
    assert "draft = true" in model.read_text()
    db = tmp_path / "h.db"
    code, _, err = run(capsys, "history", "import", "--db", str(db), str(reports))
    assert code == 0, err
    code, out, err = run(capsys, "diagnose", "--model", str(model), "--db", str(db), "--no-walk")
    assert code == 0, err
    line = next_line(out)
    assert "the model is a draft" in line and "DRAFT MODEL" in line and "none" not in line
