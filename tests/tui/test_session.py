"""The operator-session use cases: open a report, watch a folder, compare step by step."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import ParseError
from setupfix.tui.session import FolderWatch, OpenedReport, compare_steps, export_cycles, newest_report, open_report
from setupfix.usecases.compare import compare_problem
from setupfix.usecases.correct import load_request
from setupfix.usecases.export import export, offsets_text
from setupfix.usecases.requests import ReadOptions

MODEL = GUIDE_PINS / "model.toml"


def opened_report(report: Path, **inputs: Any) -> OpenedReport:
    """The report opened as the TUI opens it: the request from the operator's inputs, then the report."""
    return open_report(load_request(MODEL, **inputs), report)


def export_text(opened: OpenedReport, controller: str, cycle: int | None = None) -> str:
    return offsets_text(export_cycles(opened, controller, cycle), controller, opened.current)


def test_open_report_corrects_every_cycle() -> None:
    opened = opened_report(GUIDE_PINS / "cycle_01.csv")
    assert opened.format == "canonical" and len(opened.corrections) == 1 and opened.unmatched == 0
    assert opened.corrections[0].result.margin_after == pytest.approx(0.0822)


def test_a_report_of_another_part_gives_the_match_table_not_an_error(tmp_path: Path) -> None:
    other = tmp_path / "other.csv"
    other.write_text((GUIDE_PINS / "cycle_01.csv").read_text(encoding="utf-8").replace(" D", " Dx"), encoding="utf-8")
    opened = opened_report(other)
    assert opened.corrections == () and "matches a model dimension" in opened.problem
    assert opened.unmatched == 28


def test_an_unreadable_report_or_a_folder_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match="folder"):
        opened_report(tmp_path)


def _touch(path: Path, text: str, age: float) -> None:
    path.write_text(text, encoding="utf-8")
    t = time.time() - age
    os.utime(path, (t, t))


def test_newest_report_skips_hidden_partial_and_folders(tmp_path: Path) -> None:
    _touch(tmp_path / "a.csv", "x", 100)
    _touch(tmp_path / "b.csv", "x", 50)
    _touch(tmp_path / ".c.csv", "x", 0)
    _touch(tmp_path / "d.csv.part", "x", 0)
    (tmp_path / "sub").mkdir()
    assert newest_report(tmp_path) == tmp_path / "b.csv"
    for name in (
        "model.toml",
        "README.md",
        "generate.py",
        "setupfix.db",
        "setupfix.db-wal",
        "corrections.csv",
        "Temperatures.CSV",
    ):  # kept beside reports, never reports
        _touch(tmp_path / name, "x", 0)
    assert newest_report(tmp_path) == tmp_path / "b.csv"
    _touch(tmp_path / "e.json", "x", 0)  # a PiWeb report
    assert newest_report(tmp_path) == tmp_path / "e.json"
    assert newest_report(tmp_path / "missing") is None


def test_folder_watch_waits_until_a_fresh_file_stops_growing(tmp_path: Path) -> None:
    _touch(tmp_path / "old.csv", "x", 100)
    watch = FolderWatch(tmp_path, settle=60)
    assert watch.poll() == tmp_path / "old.csv"  # settled long ago: at once
    assert watch.poll() is None  # and only once
    new = tmp_path / "new.csv"
    new.write_text("part", encoding="utf-8")
    assert watch.poll() is None  # fresh: seen once
    new.write_text("part grown", encoding="utf-8")
    assert watch.poll() is None  # still changing
    assert watch.poll() == new  # unchanged between two polls
    assert watch.poll() is None


def test_compare_steps_end_with_what_compare_problem_gives() -> None:
    problem = opened_report(GUIDE_PINS / "cycle_01.csv").corrections[0].problem
    steps = list(compare_steps(problem, methods=("ga", "pso"), trials=2, seed=3))
    assert [s[1] for s in steps] == [1, 2, 3, 4, 5] and all(s[2] == 5 for s in steps)
    last, ref = steps[-1][3], compare_problem(problem, methods=("ga", "pso"), trials=2, seed=3)
    assert [m.optimizer for m in last.methods] == ["ga", "pso"]
    for a, b in zip(last.methods, ref.methods, strict=True):
        assert a.seeds == b.seeds and a.f1.tolist() == b.f1.tolist() and a.f2.tolist() == b.f2.tolist()


@pytest.mark.parametrize("controller", ["csv", "fanuc"])
def test_the_export_text_is_what_correct_writes(tmp_path: Path, controller: str) -> None:
    from setupfix.cli import main

    current = tmp_path / "current.csv"
    current.write_text(
        "register,value\n"
        + "".join(
            f"{r},{i * 0.5}\n"
            for i, r in enumerate(["G54", "G55", "G56", "G57", "G58", "G59", "G54.1P1", "G54.1P2", "H5", "H23"])
        ),
        encoding="utf-8",
    )
    opened = opened_report(GUIDE_PINS / "cycle_01.csv", current=current)
    assert opened.current is not None and opened.current["W2"] == 0.5
    assert (
        main(
            [
                "correct",
                "--model",
                str(MODEL),
                str(GUIDE_PINS / "cycle_01.csv"),
                "--offsets",
                str(tmp_path / "cli.txt"),
                "--controller",
                controller,
                "--current",
                str(current),
            ]
        )
        == 0
    )
    assert export_text(opened, controller) == (tmp_path / "cli.txt").read_text(encoding="utf-8")


def test_a_rejected_report_cannot_be_exported(tmp_path: Path) -> None:
    from setupfix.core.errors import ExportError

    gross = tmp_path / "gross.csv"
    gross.write_text(
        (GUIDE_PINS / "cycle_01.csv")
        .read_text(encoding="utf-8")
        .replace("P1 D1,25.0000,24.9691,-0.0309", "P1 D1,25.0000,24.5000,-0.5000"),
        encoding="utf-8",
    )
    opened = opened_report(gross)
    assert opened.corrections[0].verdict == "reject"
    with pytest.raises(ExportError, match="rejected"):
        export_text(opened, "csv")


def test_a_register_the_format_cannot_express_is_named() -> None:
    from setupfix.core.errors import ExportError

    with pytest.raises(ExportError, match="G58"):
        export_text(opened_report(GUIDE_PINS / "cycle_01.csv"), "siemens")


def test_the_readers_options_and_notes_come_as_data() -> None:
    opened = opened_report(GUIDE_PINS.parent / "pcdmis" / "bracket_two_parts.txt")
    assert opened.format == "pcdmis" and any("angle" in str(n) and ":27" in str(n) for n in opened.notes)
    tables = GUIDE_PINS.parent / "tables"
    shop = opened_report(
        tables / "cycle_01_shop.csv", read=ReadOptions(columns=str(tables / "cycle_01_shop.columns.toml"))
    )
    plain = opened_report(GUIDE_PINS / "cycle_01.csv")
    assert shop.corrections[0].corrections == plain.corrections[0].corrections


def test_the_report_is_read_once(monkeypatch: pytest.MonkeyPatch) -> None:
    import parsers

    files: list[object] = []
    reads: list[object] = []
    load, read = parsers.load_source, parsers.read_report

    def counted_load(source: Any, *a: Any, **k: Any) -> parsers.Source:
        if not isinstance(source, parsers.Source):
            files.append(source)
        return load(source, *a, **k)

    def counted_read(source: Any, *a: Any, **k: Any) -> parsers.ReadResult:
        reads.append(source)
        return read(source, *a, **k)

    monkeypatch.setattr(parsers, "load_source", counted_load)
    monkeypatch.setattr(parsers, "read_report", counted_read)
    assert opened_report(GUIDE_PINS / "cycle_01.csv").corrections
    assert len(files) == 1 and len(reads) == 1


@pytest.mark.slow
def test_a_program_holds_the_chosen_cycle_and_only_it_is_recorded_as_applied(tmp_path: Path) -> None:
    """Issue 21 item 5: recording an export recorded every cycle's corrections; now exactly what was written."""
    from setupfix.core.errors import ExportError
    from setupfix.store import open_store
    from setupfix.tui.session import record_applied

    opened = opened_report(GUIDE_PINS.parent / "closed_loop" / "measurements.csv")
    assert len(opened.corrections) == 40
    with pytest.raises(ExportError, match="40 cycles"):
        export_text(opened, "fanuc")
    text = export_text(opened, "fanuc", cycle=35)
    assert opened.corrections[35].part.part.upper() in text and opened.corrections[0].part.part.upper() not in text
    assert export_text(opened, "csv", cycle=35).count("\n") == 1 + 40 * 10  # csv: every cycle, as correct writes
    exported = export(export_cycles(opened, "fanuc", 35), str(tmp_path / "o.nc"), controller="fanuc")
    assert exported.text == text == (tmp_path / "o.nc").read_text(encoding="utf-8")
    added = record_applied(tmp_path / "h.db", exported, opened.corrections, when="2026-11-03T12:00:00")
    last = opened.corrections[35]
    moved = {r.register: v for r, v in zip(last.model.registers, last.x, strict=True) if v}
    with open_store(tmp_path / "h.db") as store:
        log = store.corrections()
        recs = store.recommendations()
    assert added == len(moved) > 0
    assert dict(zip(log["register"], log["delta"], strict=True)) == pytest.approx(moved)
    assert [r.inputs["part"] for r in recs] == [last.part.part] and recs[0].inputs["export"]["controller"] == "fanuc"


def test_the_folder_watch_names_what_it_cannot_look_at_once(tmp_path: Path) -> None:
    _touch(tmp_path / "a.csv", "x", 100)
    os.symlink(tmp_path / "missing.csv", tmp_path / "gone.csv")
    watch = FolderWatch(tmp_path, settle=0)
    assert watch.poll() == tmp_path / "a.csv"
    assert watch.problems == ((str(tmp_path / "gone.csv"), "broken link"),)
    assert watch.poll() is None and not watch.problems  # said once
