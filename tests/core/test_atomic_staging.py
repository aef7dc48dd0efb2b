"""A set of files written whole or not at all (issue 37, item 16 a): the staging helpers of setupfix.core.atomic."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from setupfix.core.atomic import STAGING_PREFIX, discard_staging, publish_staged, staging_folder
from setupfix.core.errors import ExportError


def tree(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): p.read_text() for p in sorted(root.rglob("*")) if p.is_file()}


def test_a_new_folder_appears_whole_and_nothing_of_it_exists_before(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b" / "programs"
    staging = staging_folder(target)
    assert not (tmp_path / "a").exists() or not target.exists()
    assert staging.parent == tmp_path and staging.name.startswith(".programs.")
    (staging / "x").mkdir()
    (staging / "x" / "one.nc").write_text("1\n")
    (staging / "two.nc").write_text("2\n")
    assert not target.exists()
    publish_staged(staging, target, ["x/one.nc", "two.nc"])
    assert tree(target) == {"x/one.nc": "1\n", "two.nc": "2\n"} and not staging.exists()


def test_an_existing_folder_stages_inside_and_keeps_what_it_does_not_replace(tmp_path: Path) -> None:
    target = tmp_path / "programs"
    target.mkdir()
    (target / "keep.nc").write_text("mine\n")
    (target / "old.nc").write_text("old\n")
    staging = staging_folder(target)
    assert staging.parent == target and staging.name.startswith(STAGING_PREFIX)
    (staging / "old.nc").write_text("new\n")
    (staging / "sub").mkdir()
    (staging / "sub" / "n.nc").write_text("n\n")
    publish_staged(staging, target, ["old.nc", "sub/n.nc"])
    assert tree(target) == {"keep.nc": "mine\n", "old.nc": "new\n", "sub/n.nc": "n\n"}


@pytest.mark.parametrize("blocker", ["folder", "file-on-the-way", "link"])
def test_a_destination_that_cannot_take_its_file_leaves_every_destination_as_it_was(
    tmp_path: Path, blocker: str
) -> None:
    target = tmp_path / "programs"
    target.mkdir()
    (target / "a.nc").write_text("old a\n")
    if blocker == "folder":
        (target / "z.nc").mkdir()
        last = "z.nc"
    elif blocker == "file-on-the-way":
        (target / "sub").write_text("a file where a folder should be\n")
        last = "sub/z.nc"
    else:
        (target / "z.nc").symlink_to(tmp_path / "elsewhere.nc")
        last = "z.nc"
    before = tree(target)
    staging = staging_folder(target)
    (staging / "a.nc").write_text("new a\n")
    (staging / last).parent.mkdir(parents=True, exist_ok=True)
    (staging / last).write_text("z\n")
    with pytest.raises(ExportError):
        publish_staged(staging, target, ["a.nc", last])  # a.nc comes first: not replaced either
    discard_staging(staging)
    assert tree(target) == before and not staging.exists()
    assert not (tmp_path / "elsewhere.nc").exists()


def test_a_file_as_target_is_refused_and_dead_staging_folders_are_removed(tmp_path: Path) -> None:
    (tmp_path / "plain").write_text("x")
    with pytest.raises(ExportError, match="not a folder"):
        staging_folder(tmp_path / "plain")
    target = tmp_path / "programs"
    target.mkdir()
    dead = target / f"{STAGING_PREFIX}.999999999.0123456789ab.tmp"
    dead.mkdir()
    live = target / f"{STAGING_PREFIX}.{os.getpid()}.0123456789ab.tmp"
    live.mkdir()
    staging = staging_folder(target)
    assert not dead.exists() and live.exists() and staging.exists()
    discard_staging(staging)
    discard_staging(live)
