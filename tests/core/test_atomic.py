"""Atomic output: complete or absent, never half-written; ordinary permissions."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from setupfix.core.atomic import STALE_AGE_S, atomic_write, check_target, write_text
from setupfix.core.errors import ExportError

ROOT = Path(__file__).resolve().parents[2]


def test_failure_leaves_old_content_and_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    with pytest.raises(RuntimeError), atomic_write(target) as stream:
        stream.write("half")
        raise RuntimeError("disk full")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_text_and_binary_with_plain_permissions(tmp_path: Path) -> None:
    with atomic_write(tmp_path / "a.txt") as stream:
        stream.write("ä\n")
    with atomic_write(tmp_path / "b.png", binary=True) as stream:
        stream.write(b"\x89PNG")
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "ä\n"
    assert (tmp_path / "b.png").read_bytes() == b"\x89PNG"
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o666 & ~umask


def test_missing_folder_is_an_export_error(tmp_path: Path) -> None:
    with pytest.raises(ExportError, match="no-such-dir"), atomic_write(tmp_path / "no-such-dir" / "x.csv") as stream:
        stream.write("x")


# -- output targets (issue 10): only '-' or a regular file ----------------------------------------


def _fifo(p: Path) -> Path:
    os.mkfifo(p)
    return p


def _link(p: Path) -> Path:
    real = p.parent / "real.csv"
    real.write_text("keep\n")
    p.symlink_to(real)
    return p


def _socket(p: Path) -> Path:
    import socket

    with socket.socket(socket.AF_UNIX) as s:  # the socket file stays after the socket is closed
        s.bind(str(p))
    return p


@pytest.mark.parametrize(
    ("make", "kind"),
    [
        (lambda p: (p.mkdir(), p)[1], "folder"),
        (_fifo, "FIFO"),
        (_link, "symbolic link"),
        (_socket, "socket"),
    ],
)
def test_non_regular_targets_are_refused_and_left_alone(
    tmp_path: Path, make: Callable[[Path], Path], kind: str
) -> None:
    target = make(tmp_path / "out.csv")
    before = os.lstat(target).st_mode
    with pytest.raises(ExportError, match=f"out.csv.*{kind}"):
        write_text(target, "x\n")
    assert os.lstat(target).st_mode == before
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize(("device", "kind"), [("/dev/null", "character device"), ("/dev/stdout", "symbolic link")])
def test_devices_are_refused(device: str, kind: str) -> None:
    if not os.path.lexists(device):
        pytest.skip(f"{device} absent")
    with pytest.raises(ExportError, match=kind):
        check_target(device)


def test_check_target_accepts_stdout_new_and_existing_regular_files(tmp_path: Path) -> None:
    assert check_target("-") is None
    assert check_target(tmp_path / "new.csv") == tmp_path / "new.csv"
    (tmp_path / "old.csv").write_text("x")
    assert check_target(tmp_path / "old.csv") == tmp_path / "old.csv"
    with pytest.raises(ExportError, match="does not exist"):
        check_target(tmp_path / "missing" / "x.csv")


def test_existing_file_keeps_its_permissions(tmp_path: Path) -> None:
    target = tmp_path / "private.csv"
    target.write_text("old")
    target.chmod(0o600)
    write_text(target, "new")
    assert target.read_text() == "new"
    assert stat.S_IMODE(target.stat().st_mode) == 0o600


# -- threads: no umask toggling, every file complete -----------------------------------------------


def test_many_threads_at_once_get_plain_permissions_and_whole_files(tmp_path: Path) -> None:
    old = os.umask(0o027)
    try:

        def work(i: int) -> int:
            write_text(tmp_path / f"f{i % 8}.csv", f"{i}\n" * 500)
            plain = tmp_path / f"plain{i}.txt"  # created meanwhile with open(): must see the umask too
            plain.write_text("p")
            return stat.S_IMODE(plain.stat().st_mode)

        with ThreadPoolExecutor(max_workers=16) as pool:
            plain_modes = set(pool.map(work, range(200)))
    finally:
        os.umask(old)
    assert plain_modes == {0o640}
    for i in range(8):
        f = tmp_path / f"f{i}.csv"
        lines = f.read_text().splitlines()
        assert len(lines) == 500 and len(set(lines)) == 1  # one writer's whole content
        assert stat.S_IMODE(f.stat().st_mode) == 0o640
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# -- stale temporary files of killed writes ---------------------------------------------------------


def test_kill_mid_write_leaves_old_content_and_next_write_cleans_up(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    code = (
        "import os, signal, sys; from setupfix.core.atomic import atomic_write\n"
        "with atomic_write(sys.argv[1]) as s:\n"
        "    s.write('half'); s.flush(); os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(target)], cwd=ROOT, capture_output=True)
    assert proc.returncode == -signal.SIGKILL
    assert target.read_text() == "old\n"
    left = [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert len(left) == 1 and left[0].startswith(".out.csv.")
    live = tmp_path / f".out.csv.{os.getpid()}.abc123.tmp"  # a write of this (running) process
    live.write_text("busy")
    legacy_old, legacy_new = tmp_path / ".out.csv.k2j4h5g6.tmp", tmp_path / ".out.csv.q9w8e7r6.tmp"
    legacy_old.write_text("x")
    legacy_new.write_text("x")
    os.utime(legacy_old, (time.time() - 2 * STALE_AGE_S,) * 2)
    other = tmp_path / ".other.csv.1.abc.tmp"
    other.write_text("not ours")
    write_text(target, "new\n")
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")) == sorted(
        [live.name, legacy_new.name, other.name]
    )
