"""parse, model init, history import and diagnose see the same reports in a folder: parsers.list_reports.

The folder holds what a shop folder holds: PC-DMIS text reports (``.txt``, which
``diagnose`` once dropped by suffix), a hidden copy, a process model, a file still being
written, the series logs, a report linked in from elsewhere, a sub-folder and a link to
a folder (named, not followed).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from parsers import list_reports
from setupfix.cli import main
from setupfix.core.errors import MatchError
from setupfix.inputs.series import load_series
from setupfix.model import load_model
from setupfix.store import open_store
from setupfix.usecases.diagnosis import note_text
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.usecases.model_init import scaffold_model
from setupfix.usecases.parse import parse_reports

ROOT = Path(__file__).resolve().parents[2]
PCDMIS = ROOT / "sample_reports" / "pcdmis"
LINK_PROBLEM = "link to a folder: not followed; left out"


@pytest.fixture
def shop(tmp_path: Path) -> tuple[Path, Path]:
    """(folder, model written from it)."""
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    shutil.copy(PCDMIS / "bracket_minus_negative.txt", outside / "bracket_minus_negative.txt")
    root = tmp_path / "shop"
    (root / "sub").mkdir(parents=True)
    shutil.copy(PCDMIS / "bracket_two_parts.txt", root / "bracket_two_parts.txt")
    shutil.copy(PCDMIS / "bracket_two_parts.txt", root / "sub" / "again.txt")
    shutil.copy(PCDMIS / "bracket_two_parts.txt", root / ".hidden.txt")
    shutil.copy(PCDMIS / "bracket_two_parts.txt", root / "late.txt.part")
    os.symlink(outside / "bracket_minus_negative.txt", root / "linked.txt")
    os.symlink(outside, root / "folder_link")
    model = tmp_path / "model.toml"
    # one axis (Z): a multi-axis scaffold of the X/Y/Z report would need the multi-axis loader (issue 23)
    model.write_text(scaffold_model([PCDMIS / "bracket_two_parts.txt"], axis="Z").text, encoding="utf-8")
    shutil.copy(model, root / "model.toml")
    (root / "corrections.csv").write_text("Timestamp,Register,Delta\n2026-11-02T07:00:00,W1,0.01\n", encoding="utf-8")
    (root / "temperatures.csv").write_text("timestamp,spindle\n2026-11-02T06:00:00,20.1\n", encoding="utf-8")
    return root, model


def _expected(root: Path) -> list[str]:
    listing = list_reports(root)
    names = [str(p) for p in listing.paths]
    assert [Path(n).relative_to(root).as_posix() for n in names] == [
        "bracket_two_parts.txt",
        "linked.txt",
        "sub/again.txt",
    ]  # the policy itself, pinned
    assert dict(listing.problems) == {str(root / "folder_link"): "link to a folder: not followed"}
    assert listing.log("corrections") == str(root / "corrections.csv")
    return names


def test_parse_reads_the_listed_reports_and_warns_of_the_folder_link(
    shop: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    root, _ = shop
    outcome = parse_reports([root])
    assert [r.path for r in outcome.reports] == _expected(root) and list(outcome.failures) == []
    target = (root.parent / "elsewhere" / "bracket_minus_negative.txt").resolve()
    linked = f"{root / 'linked.txt'}: symbolic link to {target}: read as a report"  # said, not read silently
    assert [str(n) for n in outcome.problems] == [f"{root / 'folder_link'}: {LINK_PROBLEM}", linked]
    assert main(["parse", str(root), "--out", str(tmp_path / "all.csv")]) == 0
    err = capsys.readouterr().err
    assert f"warning: {root / 'folder_link'}: {LINK_PROBLEM}" in err and f"warning: {linked}" in err


def test_model_init_reads_the_listed_reports(shop: tuple[Path, Path]) -> None:
    root, _ = shop
    scaffold = scaffold_model([root])
    head = scaffold.text.splitlines()[0]
    assert head.endswith("from: " + ", ".join(Path(n).name for n in _expected(root)))
    assert f"{root / 'folder_link'}: {LINK_PROBLEM}" in map(str, scaffold.notes)


def test_history_import_stores_the_listed_reports_and_the_logs_found(shop: tuple[Path, Path], tmp_path: Path) -> None:
    root, model = shop
    with open_store(tmp_path / "h.db") as store:
        summary = import_history(store, ImportRequest((root,), model=load_model(model)))
        assert list(summary.new_reports + summary.known_reports) == _expected(root)
        assert list(summary.known_reports) == [str(root / "sub" / "again.txt")]  # the same bytes as the first
        assert (summary.corrections, summary.temperatures) == (1, 1)
        assert f"{root / 'folder_link'}: {LINK_PROBLEM}" in map(str, summary.notes)
        assert [r.name for r in store.reports()] == ["bracket_two_parts.txt", "linked.txt"]


def test_diagnose_reads_the_listed_reports_and_uses_the_logs_found(shop: tuple[Path, Path]) -> None:
    root, model = shop
    expected = _expected(root)
    # the logs beside the reports are used: these PC-DMIS reports carry no time to tie them to
    with pytest.raises(MatchError, match="the reports carry no timestamps, so the corrections or temperature log"):
        load_series(model, [root])
    (root / "corrections.csv").unlink()
    (root / "temperatures.csv").unlink()
    series = load_series(model, [root])
    # parts name their file; sub/again.txt is a copy of bracket_two_parts.txt: its parts 0041 and 0042 are
    # the same measurements, used once (the later read is kept, issue 37 item 13), and 0043 (linked)
    assert sorted({p.report for p in series.parts}) == sorted(Path(n).name for n in expected[1:])
    assert f"warning: {root / 'folder_link'}: {LINK_PROBLEM}" in [note_text(n) for n in series.notes]
    assert sum("are one part" in note_text(n) for n in series.notes) == 2
    assert series.series.n_cycles == 3


def test_diagnose_says_the_folder_problem_as_a_warning(
    shop: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    root, model = shop
    for log in ("corrections.csv", "temperatures.csv"):
        (root / log).unlink()
    assert main(["diagnose", "--model", str(model), "--no-walk", str(root)]) == 0
    assert f"\nwarning: {root / 'folder_link'}: {LINK_PROBLEM}\n" in capsys.readouterr().out


def test_a_folder_with_nothing_readable_is_refused_naming_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "model.toml").write_text("")
    os.symlink(tmp_path, empty / "up")
    model = str(ROOT / "sample_reports" / "guide_pins" / "model.toml")
    assert main(["diagnose", "--model", model, str(empty)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"error: {empty}: no report found") and f"{empty / 'up'}: {LINK_PROBLEM}" in err
    assert main(["model", "init", str(empty), "-o", str(tmp_path / "m.toml")]) == 1
    assert capsys.readouterr().err.startswith(f"error: {empty}: folder holds no report file")
