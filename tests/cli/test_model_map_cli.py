"""``setupfix model init`` then ``model map``: the questions listed, answered from options and a CSV, refusals."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from conftest import SAMPLES

from setupfix.cli import main

PLATE = str(SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF")


def _init(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    model = tmp_path / "plate.toml"
    assert main(["model", "init", PLATE, "-o", str(model)]) == 0
    err = capsys.readouterr().err
    assert "question(s) open" in err and f"setupfix model map {model}" in err
    assert "1 position zone(s)" in err
    return model


def test_map_lists_the_questions_then_answers_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = _init(tmp_path, capsys)
    assert main(["model", "map", str(model)]) == 0
    out = capsys.readouterr().out
    # 21 features asked; DS002 and DS003 are QIF DistanceBetween callouts: distances no work offset moves, not asked
    assert "21 open question(s)" in out and "CYLINDER2 (F2, F3)" in out and "POSITION1" in out
    assert "DS002" not in out and "DS003" not in out
    assert "18.27, 65.66, 2.295" in out
    assert main(["model", "map", str(model), "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert listing["draft"] is True and len(listing["questions"]) == 21
    q2 = next(q for q in listing["questions"] if q["name"] == "Q2")
    assert q2["label"] == "CYLINDER2" and {f["role"] for f in q2["features"]} == {"size", "location"}
    answers = tmp_path / "answers.csv"
    answers.write_text("feature,wks,tool\nDIAMETER5*,,T2\nCYLINDER*,G54,T4\n", encoding="utf-8")
    assert main(["model", "map", str(model), "--answers", str(answers), "--answer", "*=G54,T9"]) == 0
    out = capsys.readouterr().out
    assert "21 question(s) answered" in out and "draft = true removed" in out
    raw = tomllib.loads(model.read_text(encoding="utf-8"))
    assert set(raw["tools"]) == {"T2", "T4", "T9"} and "draft" not in raw["process"]
    assert main(["model", "map", str(model)]) == 0
    assert "no open question; the model is not a draft" in capsys.readouterr().out


def test_map_writes_elsewhere_keeps_the_draft_on_request_and_refuses_cleanly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _init(tmp_path, capsys)
    before = model.read_bytes()
    out = tmp_path / "answered.toml"
    assert main(["model", "map", str(model), "--answer", "*=G54,T1", "-o", str(out), "--keep-draft", "--json"]) == 0
    written = json.loads(capsys.readouterr().out)
    assert written["remaining"] == [] and written["draft"] is True and model.read_bytes() == before
    assert tomllib.loads(out.read_text(encoding="utf-8"))["process"]["draft"] is True
    code = main(["model", "map", str(model), "--answer", "NOTHING=G54,T1"])
    err = capsys.readouterr().err
    assert code != 0 and "--answer #1" in err and "selects no open question" in err
    assert "Traceback" not in err and model.read_bytes() == before
    bad = tmp_path / "bad.csv"
    bad.write_text("feature,tool\nQ1,T1\n", encoding="utf-8")
    code = main(["model", "map", str(model), "--answers", str(bad)])
    err = capsys.readouterr().err
    assert code != 0 and f"{bad}:1" in err and "missing column(s) wks" in err
