"""``correct`` offers the name a mistyped characteristic meant (issue 37 item 10), by the rule ``model check``
uses (:func:`setupfix.model.measurements.closest_names`): ``P1-D4`` → ``P1 D4``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main
from setupfix.model import load_model
from setupfix.model.measurements import closest_names
from setupfix.usecases.correct import correct_report
from setupfix.usecases.model_check import check_report
from setupfix.usecases.requests import CorrectRequest

MODEL = GUIDE_PINS / "model.toml"


def renamed(tmp_path: Path, old: str, new: str) -> Path:
    text = (GUIDE_PINS / "cycle_02.csv").read_text()
    assert text.count(f"\n{old},") == 1
    path = tmp_path / "renamed.csv"
    path.write_text(text.replace(f"\n{old},", f"\n{new},"))
    return path


@pytest.mark.parametrize(
    ("old", "new"), [("P1 D4", "P1-D4"), ("P3 D7", "p3_d7"), ("P2 D1", "P2D1"), ("P4 D5", "P4 D5 .")]
)
def test_correct_says_which_dimension_a_name_meant(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str
) -> None:
    report = renamed(tmp_path, old, new)
    (cycle,) = correct_report(CorrectRequest(load_model(MODEL)), report).cycles
    line = next(str(n) for n in cycle.notes if "match no dimension" in str(n))
    assert f"{new} (did you mean {old!r}?)" in line
    assert main(["correct", "--model", str(MODEL), "--json", str(report)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert any(f"did you mean {old!r}?" in w for w in doc["warnings"])
    # model check ties the same two names, both ways, by the same rule
    table = check_report(MODEL, report)
    (row,) = (r for r in table.rows(table.parts[0]) if r["name"] == old)
    assert row["closest"][0] == new and closest_names(new, [old, "P9 D9"])[0] == old


def test_no_guess_at_a_dimension_the_report_measures(tmp_path: Path) -> None:
    """``P1 D44`` is close to ``P1 D4``, but P1 D4 is measured: nothing absent to mean, no guess."""
    text = (GUIDE_PINS / "cycle_02.csv").read_text()
    line = next(li for li in text.splitlines() if li.startswith("P1 D4,"))
    path = tmp_path / "extra.csv"
    path.write_text(text + line.replace("P1 D4,", "P1 D44,") + "\n")
    (cycle,) = correct_report(CorrectRequest(load_model(MODEL)), path).cycles
    note = next(str(n) for n in cycle.notes if "match no dimension" in str(n))
    assert note.endswith("match no dimension: P1 D44")
