"""Batch correction of a folder tree: good, bad, duplicate and changing files; store; workers."""

from __future__ import annotations

import dataclasses
import functools
import os
import shutil
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from setupfix.model import load_model
from setupfix.outputs.batch_output import MANIFEST
from setupfix.store import open_store
from setupfix.usecases.batch import run_batch
from setupfix.usecases.batch_records import Outcome
from setupfix.usecases.requests import CorrectRequest, SolveOptions

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
MODEL = load_model(GUIDE / "model.toml")
REQUEST = CorrectRequest(MODEL)


def folder(tmp_path: Path) -> Path:
    d = tmp_path / "reports"
    (d / "sub").mkdir(parents=True)
    for i in (1, 2, 3):
        shutil.copy(GUIDE / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    shutil.copy(GUIDE / "cycle_01.qif", d / "sub" / "cycle_01.qif")
    shutil.copy(GUIDE / "cycle_02.csv", d / "sub" / "copy_of_02.csv")
    (d / "sub" / "notes.txt").write_text("not a report\n")
    (d / ".hidden.csv").write_text("ignored\n")
    return d


def test_good_bad_and_duplicate_reports(tmp_path: Path) -> None:
    d = folder(tmp_path)
    out = tmp_path / "offsets.csv"
    s = run_batch(REQUEST, d, out, settle=0)
    assert (s.reports, s.parts, s.verdicts["apply"]) == (3, 3, 3)
    assert [Path(f).name for f, _ in s.failed] == ["notes.txt"] and "no reader accepts" in s.failed[0][1]
    # the QIF of cycle 01 is the same measurement as its CSV (issue 37 item 13): named, corrected once
    assert [(Path(f).name, r) for f, r in s.skipped] == [
        ("copy_of_02.csv", f"same content as {d / 'cycle_02.csv'}"),
        ("cycle_01.qif", f"same measurement as {d / 'cycle_01.csv'} (part 'cycle 01')"),
    ]
    lines = out.read_text().splitlines()
    assert len(lines) == 1 + 3 * 10  # header + 10 registers per report
    assert {line.split(",")[0] for line in lines[1:]} == {"cycle_01.csv", "cycle_02.csv", "cycle_03.csv"}


def test_rerun_is_idempotent_and_workers_do_not_change_numbers(tmp_path: Path) -> None:
    d = folder(tmp_path)
    run_batch(REQUEST, d, tmp_path / "a.csv", settle=0)
    run_batch(REQUEST, d, tmp_path / "a.csv", settle=0)
    run_batch(REQUEST, d, tmp_path / "b.csv", settle=0, workers=2)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "b.csv", "reports"]  # no temp files


def test_store_skips_processed_reports_unless_forced(tmp_path: Path) -> None:
    d = folder(tmp_path)
    out = tmp_path / "offsets.csv"
    with open_store(tmp_path / "h.db") as store:
        first = run_batch(REQUEST, d, out, settle=0, store=store)
        text = out.read_text()
        again = run_batch(REQUEST, d, out, settle=0, store=store)
        forced = run_batch(REQUEST, d, out, settle=0, store=store, force=True)
        assert len(store.reports()) == 3
    assert first.reports == 3 and again.reports == 0 and not again.written and forced.reports == 3
    assert sum("already processed" in r for _, r in again.skipped) == 4
    # the QIF of cycle 01 is not stored (a copy of its CSV's measurement): the next run knows it by the store
    assert [(Path(f).name, r) for f, r in again.skipped if "already processed" not in r] == [
        ("cycle_01.qif", "same measurement as cycle_01.csv in the history store (part 'cycle 01')")
    ]
    assert out.read_text() == text  # nothing new: the previous output is left as it was


def test_file_changing_during_the_run_is_not_read(tmp_path: Path) -> None:
    d = folder(tmp_path)
    late = d / "sub" / "cycle_01.qif"

    def touch(done: int, total: int, outcome: object) -> None:
        if done == 1:
            late.write_bytes(late.read_bytes() + b"\n")

    s = run_batch(REQUEST, d, tmp_path / "o.csv", settle=0, progress=touch)
    assert any(Path(f) == late and "still being written" in r for f, r in s.failed)


def test_bad_controller_register_fails_before_any_work(tmp_path: Path) -> None:
    from setupfix.core.errors import ExportError

    with pytest.raises(ExportError, match=r"haas: cannot express register 'G54.1P1'"):
        run_batch(REQUEST, folder(tmp_path), tmp_path / "programs", settle=0, controller="haas")
    assert not (tmp_path / "programs").exists()


def test_one_program_per_cycle(tmp_path: Path) -> None:
    sample = ROOT / "sample_reports" / "controllers"
    d = tmp_path / "r"
    d.mkdir()
    shutil.copy(sample / "report.csv", d / "a.csv")
    request = CorrectRequest(load_model(sample / "model.toml"), solve=SolveOptions(objective="paper"))  # README's
    s = run_batch(request, d, tmp_path / "programs", settle=0, controller="fanuc")
    assert s.written and sorted(p.name for p in (tmp_path / "programs").iterdir()) == [MANIFEST, "a.csv.nc"]
    assert "G91 G10 L2 P1 Z-0.022" in (tmp_path / "programs" / "a.csv.nc").read_text()


def test_store_records_what_was_corrected_without_reading_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With a history store each report is read once (in the worker): the store gets those bytes and that table."""
    import parsers

    d = folder(tmp_path)
    calls: list[str] = []
    real = parsers.read_report

    def counted(source, **options):  # type: ignore[no-untyped-def]
        calls.append(str(source))
        return real(source, **options)

    monkeypatch.setattr(parsers, "read_report", counted)
    with open_store(tmp_path / "h.db") as store:
        s = run_batch(REQUEST, d, tmp_path / "offsets.csv", settle=0, store=store)
        assert s.reports == 3 and len(store.reports()) == 3  # the QIF repeats cycle_01.csv
        stored = store.measurements(store.reports()[0].sha256)
    assert sorted(Path(c).name for c in calls) == sorted(
        ["cycle_01.csv", "cycle_02.csv", "cycle_03.csv", "cycle_01.qif", "copy_of_02.csv", "notes.txt"]
    )
    table = real(GUIDE / "cycle_01.csv").table
    assert stored["characteristic"].tolist() == table["characteristic"].tolist()
    assert stored["deviation"].tolist() == pytest.approx(table["deviation"].tolist(), abs=0)


@pytest.mark.slow
def test_many_reports_in_chunks_give_the_same_output_and_progress_order(tmp_path: Path) -> None:
    from setupfix.usecases.batch import chunk_size

    d = tmp_path / "reports"
    d.mkdir()
    texts = [(GUIDE / f"cycle_0{i}.csv").read_text() for i in range(1, 6)]
    for k in range(45):
        (d / f"r{k:03d}.csv").write_text(texts[k % 5].replace("T08:00:00", f"T09:00:{k:02d}"))
    (d / "r020.csv").write_text("characteristic,nominal\n")  # one bad file inside a chunk
    assert chunk_size(45, 2) == 3 and chunk_size(1000, 2) == 16 and chunk_size(1, 2) == 1
    seen: dict[int, list[str]] = {1: [], 2: []}

    def record_name(names: list[str], done: int, total: int, o: Outcome) -> None:
        names.append(Path(o.path).name)

    for workers in (1, 2):
        s = run_batch(
            REQUEST,
            d,
            tmp_path / f"w{workers}.csv",
            settle=0,
            workers=workers,
            progress=functools.partial(record_name, seen[workers]),
        )
        assert (s.reports, len(s.failed)) == (44, 1) and "r020.csv" in s.failed[0][0]
    assert seen[1] == seen[2] == sorted(p.name for p in d.iterdir())
    assert (tmp_path / "w1.csv").read_bytes() == (tmp_path / "w2.csv").read_bytes()


def test_files_kept_beside_reports_are_not_read_as_reports(tmp_path: Path) -> None:
    """A model, notes, scripts, the store, the logs and partial files beside the reports are left out
    (they were 'failed' before, so a clean folder exited 4); every other file is tried, whatever its
    extension; what cannot be looked at (a broken link) is named as failed, never dropped."""
    import os

    d = tmp_path / "in"
    d.mkdir()
    for name in (
        "model.toml",
        "README.md",
        "generate.py",
        "setupfix.db",
        "setupfix.db-wal",
        "corrections.csv",
        "TEMPERATURES.csv",
        "r1.csv",
        "r2.qif",
        "values.json",
        "k.txt",
        "odd.report",
        "r3.csv.part",
    ):
        (d / name).write_text("x")
    os.symlink(d / "missing.csv", d / "gone.csv")
    s = run_batch(REQUEST, d, tmp_path / "out.csv", settle=0)
    assert sorted(Path(f).name for f, _ in s.failed) == sorted(
        ["gone.csv", "r1.csv", "r2.qif", "values.json", "k.txt", "odd.report"]
    )
    assert dict(s.failed)[str(d / "gone.csv")] == "broken link"
    summary = run_batch(REQUEST, GUIDE, tmp_path / "out.csv", settle=0)
    assert summary.reports == 5 and not summary.failed  # cycle 01's .dmo and .qif repeat its .csv


def test_automatic_worker_count(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without --workers: one process per CPU the batch may use (at most 8), one for a small folder."""
    from setupfix.usecases import batch

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(12)), raising=False)
    assert batch.auto_workers(31) == 1
    assert batch.auto_workers(32) == 8
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    assert batch.auto_workers(1000) == 2


@pytest.mark.slow
def test_ewma_over_the_store_and_the_batch_does_not_depend_on_workers(tmp_path: Path) -> None:
    """With λ < 1 and a store, each report is smoothed over every earlier part (store and batch): the same
    output for 1 and 2 workers, different from the unsmoothed one, and equal to correcting each report with
    the history of the store holding them all."""
    from setupfix.outputs.writers import csv_lines
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.export import cycle_rows
    from setupfix.usecases.requests import History

    model_path = tmp_path / "ewma.toml"
    model_path.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    request = CorrectRequest(load_model(model_path))
    d = tmp_path / "reports"
    d.mkdir()
    for i in range(1, 6):
        shutil.copy(GUIDE / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    for workers in (1, 2):
        with open_store(tmp_path / f"w{workers}.db") as store:
            s = run_batch(request, d, tmp_path / f"w{workers}.csv", settle=0, store=store, workers=workers)
        assert s.reports == 5 and not any("needs the history store" in str(n) for _, n in s.notes)
    assert (tmp_path / "w1.csv").read_bytes() == (tmp_path / "w2.csv").read_bytes()
    run_batch(request, d, tmp_path / "plain.csv", settle=0)
    assert (tmp_path / "plain.csv").read_bytes() != (tmp_path / "w1.csv").read_bytes()
    with open_store(tmp_path / "w1.db") as store:  # now holding the five reports
        full = dataclasses.replace(request, history=History.from_store(request.model, store))
    rows = [
        row for i in range(1, 6) for c in correct_report(full, d / f"cycle_0{i}.csv").cycles for row in cycle_rows(c)
    ]
    lines = (tmp_path / "w1.csv").read_text().splitlines()[1:]
    assert [line.split(",")[1:] for line in lines] == [line.split(",")[1:] for line in csv_lines(rows).splitlines()]


def test_a_report_the_store_refuses_is_said_in_the_summary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Its offsets stand (it is corrected again next run), and the summary names why it was not stored."""
    from setupfix.core.errors import StoreError

    d = folder(tmp_path)
    with open_store(tmp_path / "h.db") as store:
        real = store.add_report

        def refuse_one(data: bytes, name: str, format: str, table: pd.DataFrame, **marks: Any) -> tuple[str, bool]:
            if name == "cycle_02.csv":
                raise StoreError("the store is full", location=None)
            return real(data, name, format, table, **marks)

        monkeypatch.setattr(store, "add_report", refuse_one)
        s = run_batch(REQUEST, d, tmp_path / "offsets.csv", settle=0, store=store)
        assert len(store.reports()) == 2  # cycle_01.csv and cycle_03.csv (the QIF repeats cycle_01.csv)
    assert s.reports == 3
    said = [(Path(f).name, str(n)) for f, n in s.notes if n.kind == "store"]
    assert said == [("cycle_02.csv", "the store is full")]
