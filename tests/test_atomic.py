"""Atomic output: complete or absent, never half-written; ordinary permissions."""

from __future__ import annotations

import os
import stat

import pytest

from setupfix.atomic import atomic_write
from setupfix.errors import ExportError


def test_failure_leaves_old_content_and_no_temp(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with atomic_write(target) as stream:
            stream.write("half")
            raise RuntimeError("disk full")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_text_and_binary_with_plain_permissions(tmp_path):
    with atomic_write(tmp_path / "a.txt") as stream:
        stream.write("ä\n")
    with atomic_write(tmp_path / "b.png", binary=True) as stream:
        stream.write(b"\x89PNG")
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "ä\n"
    assert (tmp_path / "b.png").read_bytes() == b"\x89PNG"
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o666 & ~umask


def test_missing_folder_is_an_export_error(tmp_path):
    with pytest.raises(ExportError, match="no-such-dir"):
        with atomic_write(tmp_path / "no-such-dir" / "x.csv") as stream:
            stream.write("x")
