"""``[safety] mean_of`` in batch: each report averaged with the batch's reports machined before it, as ``correct``
averages it with the same parts in its history."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

import parsers
from setupfix.inputs.cycles import read_parts
from setupfix.inputs.smoothing import History
from setupfix.model import load_model
from setupfix.store import open_store
from setupfix.usecases.batch import run_batch
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest


def deltas(out: Path, report: str) -> dict[str, float]:
    lines = out.read_text().splitlines()
    head = lines[0].split(",")
    rows = [dict(zip(head, line.split(","), strict=True)) for line in lines[1:]]
    return {r["id"]: float(r["delta"]) for r in rows if r["report"] == report}


@pytest.mark.slow
def test_batch_averages_over_its_earlier_reports(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE_PINS / "model.toml").read_text() + "\n[safety]\nmean_of = 2\n")
    model = load_model(path)
    folder = tmp_path / "in"
    folder.mkdir()
    for i in (1, 2):
        shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", folder / f"cycle_0{i}.csv")
    with open_store(tmp_path / "s.db") as store:
        run_batch(CorrectRequest(model), folder, tmp_path / "out.csv", settle=0, store=store)
    got = deltas(tmp_path / "out.csv", "cycle_02.csv")
    _, parts = read_parts(model, parsers.load_source(GUIDE_PINS / "cycle_01.csv"))
    request = CorrectRequest(model, history=History.empty(model).with_parts(parts))
    (want,) = correct_report(request, GUIDE_PINS / "cycle_02.csv").cycles
    assert got == pytest.approx(want.corrections)
    alone = correct_report(CorrectRequest(load_model(GUIDE_PINS / "model.toml")), GUIDE_PINS / "cycle_02.csv")
    assert got != pytest.approx(alone.cycles[0].corrections)  # the mean is not the part alone
