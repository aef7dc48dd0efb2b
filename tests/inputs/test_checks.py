"""A report checked against the model: unit errors refused, revisions noted (refused with strict), coverage."""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import MatchError
from setupfix.model import ProcessModel
from setupfix.usecases.contract import note_lines
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, CycleOptions

CYCLE = GUIDE_PINS / "cycle_01.csv"
#: A row of the report as csv.DictReader gives it.
Row = dict[str | Any, str | Any]


def cycles(model: ProcessModel, path: Path, strict: bool = False) -> tuple[CycleCorrection, ...]:
    return correct_report(CorrectRequest(model, cycles=CycleOptions(strict=strict)), path).cycles


def rewrite(tmp_path: Path, change: Callable[[int, Row], Row], rows_slice: slice = slice(None)) -> Path:
    with open(CYCLE, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    out = tmp_path / "r.csv"
    with open(out, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, list(rows[0]))
        writer.writeheader()
        for i, row in enumerate(rows[rows_slice]):
            writer.writerow(change(i, dict(row)))
    return out


def inch_values(i: int, row: Row) -> Row:
    for key in ("nominal", "actual", "deviation", "lower", "upper"):
        row[key] = f"{float(row[key]) / 25.4:.5f}"
    return row


def test_inch_values_labelled_mm_are_a_unit_error(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    path = rewrite(tmp_path, inch_values)
    with pytest.raises(
        MatchError,
        match=r"r\.csv:2: unit error at P1 D1: .*0\.98425 mm .* 25 mm.*inch values read "
        r"as mm \(27 more",
    ):
        cycles(guide_pins_model, path)
    # labelled as what it is, the same report corrects like the original (to the register grid)
    labelled = rewrite(tmp_path, lambda i, r: {**inch_values(i, r), "unit": "inch"})
    (pc,) = cycles(guide_pins_model, labelled)
    (ref,) = cycles(guide_pins_model, CYCLE)
    assert pc.corrections == pytest.approx(ref.corrections, abs=0.0021)
    assert not [w for w in note_lines(pc.notes) if "differs" in w]


def test_mm_values_labelled_inch_are_a_unit_error(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    path = rewrite(tmp_path, lambda i, r: {**r, "unit": "inch"})
    with pytest.raises(MatchError, match=r"25.4 times too large: mm values read as inch"):
        cycles(guide_pins_model, path)


def shifted(i: int, row: Row) -> Row:
    if i == 3:
        row["nominal"] = f"{float(row['nominal']) + 100:.4f}"
        row["actual"] = f"{float(row['actual']) + 100:.4f}"
    return row


def test_shifted_nominal_is_noted_and_refused_when_strict(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    path = rewrite(tmp_path, shifted)
    (pc,) = cycles(guide_pins_model, path)
    (note,) = [w for w in note_lines(pc.notes) if "nominal" in w]
    assert "r.csv:5: P1 D4: the report's nominal 130 mm differs from the model's 30 mm" in note
    with pytest.raises(MatchError, match=r"r\.csv:5: P1 D4: .*nominal 130 mm.*refused by --strict"):
        cycles(guide_pins_model, path, strict=True)


def test_narrower_report_tolerance_is_not_silent(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    path = rewrite(tmp_path, lambda i, r: {**r, "lower": "-0.02", "upper": "0.02"})
    (pc,) = cycles(guide_pins_model, path)
    (note,) = [w for w in note_lines(pc.notes) if "tolerance" in w]
    assert "28 dimensions (P1 D1" in note and "-0.02/+0.02 mm differs from the model's -0.1/+0.1 mm" in note
    with pytest.raises(MatchError, match="refused by --strict"):
        cycles(guide_pins_model, path, strict=True)


def test_rounding_is_not_a_difference(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    # a nominal printed to three decimals less and a limit 1 µm off are rounding, not a revision
    path = rewrite(tmp_path, lambda i, r: {**r, "nominal": f"{float(r['nominal']) + 0.0004:.4f}", "upper": "0.101"})
    (pc,) = cycles(guide_pins_model, path, strict=True)
    assert not [w for w in note_lines(pc.notes) if "differs" in w]


def test_one_station_of_the_fixture_warns_about_shared_tools(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    path = rewrite(tmp_path, lambda i, r: r, slice(0, 7))
    (pc,) = cycles(guide_pins_model, path)
    (note,) = [w for w in note_lines(pc.notes) if "does not measure" in w]
    assert "a correction of T5, T23 also moves 21 dimension(s)" in note and "stations P2, P3, P4" in note
    assert "measured dimensions only" in note
    (full,) = cycles(guide_pins_model, CYCLE)
    assert not [w for w in note_lines(full.notes) if "does not measure" in w]


def test_warnings_reach_json_and_stderr(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from setupfix.cli import main

    path = rewrite(tmp_path, lambda i, r: {**r, "lower": "-0.02", "upper": "0.02"})
    assert main(["correct", "--model", str(GUIDE_PINS / "model.toml"), "--json", str(path)]) == 0
    captured = capsys.readouterr()
    assert any("differs from the model's" in w for w in json.loads(captured.out)["warnings"])
    assert "warning: " in captured.err and "-0.02/+0.02 mm differs" in captured.err
