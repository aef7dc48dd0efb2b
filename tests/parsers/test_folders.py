"""The one folder-walk policy (parsers.folders.list_reports): what is a candidate, what is named."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from parsers import list_reports


def _tree(tmp_path: Path) -> Path:
    (tmp_path / "a").mkdir(parents=True)
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


def test_candidates_sorted_depth_first_and_every_left_out_file_has_a_reason(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    listing = list_reports(root)
    assert [p.relative_to(root).as_posix() for p in listing.paths] == ["a/r1.csv", "a/report.txt", "b/r2.qif"]
    reasons = {Path(p).relative_to(root).as_posix(): why for p, why in listing.ignored}
    assert set(reasons) == {".hidden", "model.toml", "corrections.csv", "temperatures.csv", "r4.csv.part", ".r5.csv"}
    assert "log" in reasons["corrections.csv"] and "partial" in reasons["r4.csv.part"]
    assert listing.log("corrections") == str(root / "corrections.csv")
    assert listing.log("temperatures") == str(root / "temperatures.csv")
    assert listing.problems == ()


def test_not_recursive_names_sub_folders(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    listing = list_reports(root, recursive=False)
    assert listing.paths == []
    assert (str(root / "a"), "sub-folder (not searched)") in listing.ignored


def test_links_unreadable_folders_and_vanished_files_are_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _tree(tmp_path / "root")
    outside = tmp_path / "elsewhere.csv"
    outside.write_text("x")
    os.symlink(root / "a" / "r1.csv", root / "b" / "linked.csv")
    os.symlink(outside, root / "b" / "outside.csv")
    os.symlink(root / "a", root / "b" / "folder_link")
    os.symlink(root / "missing.csv", root / "b" / "broken.csv")
    listing = list_reports(root)
    # a link to a report read under its own name is left out, said; one to a file elsewhere is read, said
    assert root / "b" / "linked.csv" not in listing.paths and root / "a" / "r1.csv" in listing.paths
    assert "which is read under its own name" in dict(listing.ignored)[str(root / "b" / "linked.csv")]
    assert root / "b" / "outside.csv" in listing.paths
    assert listing.links == ((str(root / "b" / "outside.csv"), str(outside.resolve())),)
    assert [str(n) for n in listing.notes() if "symbolic link" in str(n)] == [
        f"{root / 'b' / 'outside.csv'}: symbolic link to {outside.resolve()}: read as a report"
    ]
    problems = dict(listing.problems)
    assert problems[str(root / "b" / "folder_link")] == "link to a folder: not followed"
    assert problems[str(root / "b" / "broken.csv")] == "broken link"

    real_stat = os.stat

    def vanishing(path: Any, *a: Any, **k: Any) -> os.stat_result:
        if str(path).endswith("r2.qif"):
            raise FileNotFoundError(2, "No such file or directory")
        return real_stat(path, *a, **k)

    monkeypatch.setattr(os, "stat", vanishing)
    problems = dict(list_reports(root).problems)
    assert problems[str(root / "b" / "r2.qif")] == "renamed or removed while the folder was listed"


def test_unreadable_folder_is_named_even_as_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _tree(tmp_path)
    real = os.scandir

    def refuse(path: Any) -> object:
        if str(path).endswith("/b"):
            raise PermissionError(13, "Permission denied")
        return real(path)

    monkeypatch.setattr(os, "scandir", refuse)
    problems = dict(list_reports(root).problems)
    assert problems[str(root / "b")] == "cannot list folder: permission denied"


def test_link_loops_are_named_never_followed(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    os.symlink(tmp_path, tmp_path / "sub" / "up")  # a folder loop
    os.symlink(tmp_path / "self.csv", tmp_path / "self.csv")  # a link to itself
    os.symlink(tmp_path / "pong.csv", tmp_path / "ping.csv")
    os.symlink(tmp_path / "ping.csv", tmp_path / "pong.csv")
    problems = dict(list_reports(tmp_path).problems)
    assert problems == {
        str(tmp_path / "sub" / "up"): "link to a folder: not followed",
        str(tmp_path / "self.csv"): "symbolic link loop",
        str(tmp_path / "ping.csv"): "symbolic link loop",
        str(tmp_path / "pong.csv"): "symbolic link loop",
    }


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads a chmod 000 folder")
def test_an_unreadable_sub_folder_is_named_really(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    (root / "b").chmod(0)
    try:
        listing = list_reports(root)
    finally:
        (root / "b").chmod(0o755)
    assert dict(listing.problems) == {str(root / "b"): "cannot list folder: permission denied"}
    assert root / "a" / "r1.csv" in listing.paths


def test_names_that_are_not_utf8_are_listed_and_shown_escaped(tmp_path: Path) -> None:
    raw = os.fsencode(tmp_path) + b"/bad\xffname.csv"
    with open(raw, "wb") as fh:
        fh.write(b"x")
    os.mkdir(os.fsencode(tmp_path) + b"/sub\xfe")
    os.symlink(os.fsencode(tmp_path) + b"/sub\xfe", os.fsencode(tmp_path) + b"/link\xfd")
    listing = list_reports(tmp_path)
    assert [os.fsencode(p) for p in listing.paths] == [raw]  # the real path, to be opened
    assert dict(listing.problems) == {f"{tmp_path}/link\\xfd": "link to a folder: not followed"}  # printable
    assert all(str(n).isprintable() for n in listing.notes())


def test_a_missing_root_is_a_problem_not_an_exception(tmp_path: Path) -> None:
    listing = list_reports(tmp_path / "nope")
    assert listing.files == () and listing.problems[0][1].startswith("cannot list folder")


def test_expand_inputs_takes_files_as_given_and_folders_by_the_policy(tmp_path: Path) -> None:
    from parsers import expand_inputs

    root = tmp_path / "t"
    root.mkdir()
    _tree(root)
    os.symlink(root / "a", root / "b" / "folder_link")
    (tmp_path / "empty").mkdir()
    given = root / ".r5.csv"  # hidden, but named: taken as given
    inputs = expand_inputs([given, "-", root, tmp_path / "empty", tmp_path / "missing.csv"])
    assert inputs.files == (
        (str(given), False),
        ("-", False),
        (str(root / "a" / "r1.csv"), True),
        (str(root / "a" / "report.txt"), True),
        (str(root / "b" / "r2.qif"), True),
        (str(tmp_path / "missing.csv"), False),
    )  # a missing file: its reader names it
    assert inputs.empty == (str(tmp_path / "empty"),)
    assert inputs.log("corrections") == str(root / "corrections.csv")
    assert inputs.warnings() == [f"{root / 'b' / 'folder_link'}: link to a folder: not followed; left out"]
    assert [n.kind for n in inputs.notes()] == ["folder"]
    flat = expand_inputs([root], recursive=False)
    assert flat.files == () and flat.empty == (str(root),)


def test_a_scripts_byte_code_cache_is_not_searched(tmp_path: Path) -> None:
    root = _tree(tmp_path)
    (root / "__pycache__").mkdir()
    (root / "__pycache__" / "generate.cpython-311.pyc").write_bytes(b"\x00")
    (root / "stray.pyc").write_bytes(b"\x00")
    listing = list_reports(root)
    assert not any(p.suffix == ".pyc" for p in listing.paths)
    reasons = dict(listing.ignored)
    assert "byte-code" in reasons[str(root / "__pycache__")] and "never a report" in reasons[str(root / "stray.pyc")]
