"""setupfix.usecases.export: apply/hold/reject policy, one cycle per program, atomic writing."""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import pytest
from conftest import GUIDE_PINS, SAMPLES

from setupfix.core.errors import ExportError
from setupfix.model import load_model
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import export, offsets_text
from setupfix.usecases.requests import CorrectOutcome, CorrectRequest, CurrentOffsets

CONTROLLERS = SAMPLES / "controllers"


@pytest.fixture(scope="module")
def guide() -> CorrectOutcome:
    return correct_report(CorrectRequest(load_model(GUIDE_PINS / "model.toml")), GUIDE_PINS / "cycle_01.csv")


def test_export_writes_exactly_offsets_text_with_its_hash(guide: CorrectOutcome, tmp_path: Path) -> None:
    target = tmp_path / "o.csv"
    done = export(guide.cycles, str(target))
    text = target.read_text(encoding="utf-8")
    assert text == done.text == offsets_text(guide.cycles)
    assert done.sha256 == hashlib.sha256(text.encode("utf-8")).hexdigest()
    assert done.parts == (guide.cycles[0].part.part,) and len(done.rows) == len(text.splitlines()) - 1
    assert [r.delta for r in done.rows] == [round(v, 3) + 0.0 for v in guide.cycles[0].corrections.values()]


def test_hold_exports_zero_rows_with_the_verdict(guide: CorrectOutcome, tmp_path: Path) -> None:
    cycle = guide.cycles[0]
    rec = dataclasses.replace(cycle.recommendation, verdict="hold", x=cycle.x * 0)
    held = dataclasses.replace(cycle, recommendation=rec)
    done = export([held], str(tmp_path / "h.csv"))
    assert {r.delta for r in done.rows} == {0.0} and {r.verdict for r in done.rows} == {"hold"}


def test_reject_is_refused_and_nothing_written(guide: CorrectOutcome, tmp_path: Path) -> None:
    cycle = guide.cycles[0]
    rec = dataclasses.replace(cycle.recommendation, verdict="reject", alarm="REJECT: P1 D1 beyond the band")
    rejected = dataclasses.replace(cycle, recommendation=rec)
    target = tmp_path / "r.csv"
    with pytest.raises(ExportError, match=r"cycle_01.csv.*rejected.*REJECT: P1 D1"):
        export([rejected], str(target))
    assert not target.exists()


def test_program_holds_one_cycle_and_a_failed_export_leaves_the_old_file(guide: CorrectOutcome, tmp_path: Path) -> None:
    target = tmp_path / "o.nc"
    target.write_text("old program\n")
    with pytest.raises(ExportError, match=r"cycle_01.csv.*a program holds one correction.*choose one with --part"):
        export([guide.cycles[0], guide.cycles[0]], str(target), controller="fanuc")
    with pytest.raises(ExportError, match="cannot express register 'G58'"):
        export(guide.cycles, str(target), controller="siemens")
    assert target.read_text() == "old program\n"  # atomic: complete or not at all


def test_current_offsets_make_set_rows() -> None:
    model = load_model(CONTROLLERS / "model.toml")
    current = CurrentOffsets.read(CONTROLLERS / "current.csv", model)
    out = correct_report(CorrectRequest(model, current=current), CONTROLLERS / "report.csv")
    text = offsets_text(out.cycles, "csv", current)
    assert all(",set," in line for line in text.splitlines()[1:])
    assert current.source.endswith("current.csv") and dict(current) == {k: current[k] for k in current}
