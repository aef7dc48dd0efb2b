"""The one folder-walk policy (parsers.folders.list_reports): what is a candidate, what is named."""

from __future__ import annotations

import os
from pathlib import Path

from parsers import list_reports


def _tree(tmp_path: Path) -> Path:
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "r1.csv").write_text("x")
    (tmp_path / "a" / "report.txt").write_text("x")  # PC-DMIS text: a candidate whatever its suffix
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "r2.qif").write_text("x")
    (tmp_path / ".hidden").mkdir()
    (tmp_path / ".hidden" / "r3.csv").write_text("x")
    (tmp_path / "model.toml").write_text("x")
    (tmp_path / "corrections.csv").write_text("x")
    (tmp_path / "temperatures.csv").write_text("x")
    (tmp_path / "r4.csv.part").write_text("x")
    (tmp_path / ".r5.csv").write_text("x")
    return tmp_path


def test_candidates_sorted_depth_first_and_every_left_out_file_has_a_reason(tmp_path):
    root = _tree(tmp_path)
    listing = list_reports(root)
    assert [p.relative_to(root).as_posix() for p in listing.paths] == ["a/r1.csv", "a/report.txt", "b/r2.qif"]
    reasons = {Path(p).relative_to(root).as_posix(): why for p, why in listing.ignored}
    assert set(reasons) == {".hidden", "model.toml", "corrections.csv", "temperatures.csv", "r4.csv.part", ".r5.csv"}
    assert "log" in reasons["corrections.csv"] and "partial" in reasons["r4.csv.part"]
    assert listing.log("corrections") == str(root / "corrections.csv")
    assert listing.log("temperatures") == str(root / "temperatures.csv")
    assert listing.problems == ()


def test_not_recursive_names_sub_folders(tmp_path):
    root = _tree(tmp_path)
    listing = list_reports(root, recursive=False)
    assert listing.paths == []
    assert (str(root / "a"), "sub-folder (not searched)") in listing.ignored


def test_links_unreadable_folders_and_vanished_files_are_named(tmp_path, monkeypatch):
    root = _tree(tmp_path)
    os.symlink(root / "a" / "r1.csv", root / "b" / "linked.csv")
    os.symlink(root / "a", root / "b" / "folder_link")
    os.symlink(root / "missing.csv", root / "b" / "broken.csv")
    listing = list_reports(root)
    assert root / "b" / "linked.csv" in listing.paths  # a linked report is read
    problems = dict(listing.problems)
    assert problems[str(root / "b" / "folder_link")] == "link to a folder: not followed"
    assert problems[str(root / "b" / "broken.csv")] == "broken link"

    real_stat = os.stat

    def vanishing(path, *a, **k):
        if str(path).endswith("r2.qif"):
            raise FileNotFoundError(2, "No such file or directory")
        return real_stat(path, *a, **k)

    monkeypatch.setattr(os, "stat", vanishing)
    problems = dict(list_reports(root).problems)
    assert problems[str(root / "b" / "r2.qif")] == "renamed or removed while the folder was listed"


def test_unreadable_folder_is_named_even_as_root(tmp_path, monkeypatch):
    root = _tree(tmp_path)
    real = os.scandir

    def refuse(path):
        if str(path).endswith("/b"):
            raise PermissionError(13, "Permission denied")
        return real(path)

    monkeypatch.setattr(os, "scandir", refuse)
    problems = dict(list_reports(root).problems)
    assert problems[str(root / "b")] == "cannot list folder: permission denied"


def test_a_missing_root_is_a_problem_not_an_exception(tmp_path):
    listing = list_reports(tmp_path / "nope")
    assert listing.files == () and listing.problems[0][1].startswith("cannot list folder")


def test_expand_inputs_takes_files_as_given_and_folders_by_the_policy(tmp_path):
    from parsers import expand_inputs

    root = tmp_path / "t"
    root.mkdir()
    _tree(root)
    os.symlink(root / "a", root / "b" / "folder_link")
    (tmp_path / "empty").mkdir()
    given = root / ".r5.csv"  # hidden, but named: taken as given
    inputs = expand_inputs([given, "-", root, tmp_path / "empty", tmp_path / "missing.csv"])
    assert inputs.files == ((str(given), False), ("-", False), (str(root / "a" / "r1.csv"), True),
                            (str(root / "a" / "report.txt"), True), (str(root / "b" / "r2.qif"), True),
                            (str(tmp_path / "missing.csv"), False))  # a missing file: its reader names it
    assert inputs.empty == (str(tmp_path / "empty"),)
    assert inputs.log("corrections") == str(root / "corrections.csv")
    assert inputs.warnings() == [f"{root / 'b' / 'folder_link'}: link to a folder: not followed; left out"]
    assert [n.kind for n in inputs.notes()] == ["folder"]
    flat = expand_inputs([root], recursive=False)
    assert flat.files == () and flat.empty == (str(root),)


def test_a_scripts_byte_code_cache_is_not_searched(tmp_path):
    root = _tree(tmp_path)
    (root / "__pycache__").mkdir()
    (root / "__pycache__" / "generate.cpython-311.pyc").write_bytes(b"\x00")
    (root / "stray.pyc").write_bytes(b"\x00")
    listing = list_reports(root)
    assert not any(p.suffix == ".pyc" for p in listing.paths)
    reasons = dict(listing.ignored)
    assert "byte-code" in reasons[str(root / "__pycache__")] and "never a report" in reasons[str(root / "stray.pyc")]
