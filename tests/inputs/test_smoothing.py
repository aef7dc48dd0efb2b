"""EWMA smoothing over consecutive reports from the history store (History.from_store), reset on a tool change."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

import parsers
from setupfix.core.errors import MatchError, ParseError
from setupfix.inputs.cycles import load_parts
from setupfix.model import ProcessModel, load_model
from setupfix.store import Store, open_store
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, CycleCorrection, History

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


def model_with_ewma(tmp_path: Path, lam: float) -> ProcessModel:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE / "model.toml").read_text() + f"\n[safety]\newma = {lam}\n")
    return load_model(path)


def store_with(tmp_path: Path, log_rows: list[tuple[str, str, float | None, str]]) -> Store:
    store = open_store(tmp_path / "h.db")
    for name in ("cycle_01.csv", "cycle_02.csv"):
        store.add_report((GUIDE / name).read_bytes(), name, "canonical", parsers.read(GUIDE / name))
    if log_rows:
        store.add_corrections(pd.DataFrame(log_rows, columns=["timestamp", "register", "delta", "event"]))
    return store


def correct(model: ProcessModel, report: Path, store: Store | None = None) -> tuple[CycleCorrection, ...]:
    history = History.from_store(model, store) if store is not None else None
    return correct_report(CorrectRequest(model, history=history), report).cycles


def p1d1(pc: CycleCorrection) -> dict[str, Any]:
    return next(r for r in pc.dimension_rows() if r["id"] == "P1D1")


def test_ewma_over_earlier_reports_shifted_by_applied_corrections(tmp_path: Path) -> None:
    model = model_with_ewma(tmp_path, 0.5)
    store = store_with(tmp_path, [("2026-11-02T12:00:00", "G54", 0.010, "correction")])
    (pc,) = correct(model, GUIDE / "cycle_03.csv", store)
    row = p1d1(pc)
    # cycle 01: −0.0309 + 0.010 (G54 moved since) ; cycle 02: +0.0306 ; now −0.0180
    a = -0.0209
    a = 0.5 * 0.0306 + 0.5 * a
    a = 0.5 * -0.0180 + 0.5 * a
    assert row["estimate"] == pytest.approx(a, abs=1e-12) and row["deviation"] == pytest.approx(-0.0180)
    assert pc.recommendation.rules[0].rule == "ewma" and "2 earlier part(s)" in pc.recommendation.rules[0].message
    assert row["predicted"] == pytest.approx(row["estimate"] + pc.corrections["W1"] + pc.corrections["T5"])


def test_tool_change_resets_the_dimensions_it_cuts(tmp_path: Path) -> None:
    model = model_with_ewma(tmp_path, 0.5)
    store = store_with(tmp_path, [("2026-11-03T12:00:00", "H5", None, "tool_change")])
    (pc,) = correct(model, GUIDE / "cycle_03.csv", store)
    assert p1d1(pc)["estimate"] == pytest.approx(-0.0180)  # P1 D1 = W1 + T5: history dropped


def test_without_store_not_smoothed_and_said(tmp_path: Path) -> None:
    (pc,) = correct(model_with_ewma(tmp_path, 0.5), GUIDE / "cycle_03.csv")
    assert "estimate" not in p1d1(pc) and any("needs the history store" in n.message for n in pc.notes)


def restamped(tmp_path: Path, stamp: str) -> Path:
    text = (GUIDE / "cycle_03.csv").read_text().replace("2026-11-04T08:00:00", stamp)
    path = tmp_path / "c3.csv"
    path.write_text(text)
    return path


def test_the_cycle_time_is_read_by_the_one_parser(tmp_path: Path) -> None:
    model = model_with_ewma(tmp_path, 0.5)
    store = store_with(tmp_path, [("2026-11-03T12:00:00", "G54", 0.010, "correction")])
    (ref,) = correct(model, GUIDE / "cycle_03.csv", store)
    # the same instant with an offset: compared in UTC, the same estimate
    (aware,) = correct(model, restamped(tmp_path, "2026-11-04T09:00:00+01:00"), store)
    assert p1d1(aware)["estimate"] == p1d1(ref)["estimate"]
    # 07:00 UTC on the 3rd: after cycle 01 (the 2nd, 08:00), before cycle 02 (the 3rd, 08:00)
    (early,) = correct(model, restamped(tmp_path, "2026-11-03T09:00:00+02:00"), store)
    assert "1 earlier part(s)" in early.recommendation.rules[0].message
    # not ISO 8601: refused like the diagnosis and the forecast refuse it, not read month-first and unsmoothed
    with pytest.raises(ParseError, match=r"c3\.csv: timestamp '04\.11\.2026 08:00' is not ISO 8601"):
        correct(model, restamped(tmp_path, "04.11.2026 08:00"), store)


def test_store_log_is_read_and_checked_as_diagnose_reads_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``correct --store`` smooths over the store's log read by the one reader and checked by the one model
    check, so a row ``diagnose --db`` refuses (a register the model does not know) is refused by both, at one
    place; a log the check accepts (a register by its ID or its controller name) smooths the same either way."""
    from setupfix.cli import main

    model_path = tmp_path / "m.toml"
    model_path.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    model = load_model(model_path)
    by_name = store_with(tmp_path, [("2026-11-02T12:00:00", "G54", 0.010, "correction")])
    (named,) = correct(model, GUIDE / "cycle_03.csv", by_name)
    by_name.close()
    (tmp_path / "h.db").unlink()
    by_id = store_with(tmp_path, [("2026-11-02T12:00:00", "W1", 0.010, "correction")])
    (ided,) = correct(model, GUIDE / "cycle_03.csv", by_id)
    assert p1d1(ided)["estimate"] == p1d1(named)["estimate"] != p1d1(ided)["deviation"]
    by_id.add_corrections(
        pd.DataFrame(
            [("2026-11-03T12:00:00", "H99", 0.002, "correction")], columns=["timestamp", "register", "delta", "event"]
        )
    )
    by_id.close()
    db = str(tmp_path / "h.db")
    where = f"{db}#corrections: <row 2>: unknown register 'H99'"
    with pytest.raises(MatchError, match=re.escape(where)):
        History.from_store(model, open_store(db))
    assert main(["correct", "--model", str(model_path), "--store", db, str(GUIDE / "cycle_03.csv")]) == 1
    from_correct = capsys.readouterr().err
    assert main(["diagnose", "--model", str(model_path), "--db", db, "--no-walk"]) == 1
    from_diagnose = capsys.readouterr().err
    assert where in from_correct and where in from_diagnose
    line = next(x for x in from_correct.splitlines() if where in x)
    assert line in from_diagnose.splitlines()


@pytest.mark.slow
def test_every_stored_report_counts_not_the_newest_imports(tmp_path: Path) -> None:
    """60 reports imported latest-machined first: the estimate looks at the 50 parts machined last before the
    cycle, as a history built from the same files does (the newest 50 imports would be the 50 earliest)."""
    import datetime as dt
    import sqlite3

    model = model_with_ewma(tmp_path, 0.5)
    base = pd.read_csv(GUIDE / "cycle_01.csv", dtype={"timestamp": str})
    store = open_store(tmp_path / "h.db")
    paths = []
    for k in range(60):
        table = base.copy()
        shift = 0.004 * ((k * 7) % 11 - 5)
        table["actual"] = (table["actual"] + shift).round(4)
        table["deviation"] = (table["actual"] - table["nominal"]).round(4)
        table["part"] = f"p{k}"
        table["timestamp"] = (dt.datetime(2026, 9, 1) + dt.timedelta(hours=60 - k)).isoformat()
        path = tmp_path / f"r{k:02d}.csv"
        table.to_csv(path, index=False)
        paths.append(path)
        store.add_report(path.read_bytes(), path.name, "canonical", parsers.read(path))
    assert len(store.reports()) == 60
    store.close()
    with sqlite3.connect(tmp_path / "h.db") as db:  # one import a second, in the order above
        db.execute("UPDATE report SET imported_at = printf('2026-10-01T00:00:%02d', id)")
    db.close()
    store = open_store(tmp_path / "h.db")
    stored = History.from_store(model, store)
    given = History.empty(model).with_parts([p for path in paths for p in load_parts(model, path)])
    assert len(stored.keys) == 60
    (a,) = correct_report(CorrectRequest(model, history=stored), GUIDE / "cycle_03.csv").cycles
    (b,) = correct_report(CorrectRequest(model, history=given), GUIDE / "cycle_03.csv").cycles
    assert "50 earlier part(s)" in a.recommendation.rules[0].message
    assert [r["estimate"] for r in a.dimension_rows()] == pytest.approx(
        [r["estimate"] for r in b.dimension_rows()], abs=1e-12
    )
    assert a.corrections == b.corrections
    # the 50 earliest alone (what the newest 50 imports held) give another estimate
    early = History.empty(model).with_parts([p for path in paths[10:] for p in load_parts(model, path)])
    (c,) = correct_report(CorrectRequest(model, history=early), GUIDE / "cycle_03.csv").cycles
    assert p1d1(c)["estimate"] != pytest.approx(p1d1(a)["estimate"], abs=1e-6)
