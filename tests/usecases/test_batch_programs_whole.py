"""batch --controller writes the whole program set or nothing (issue 37, item 16 a).

Variants of the issue's cases: a program number running past the format's last on the second or third program (Fanuc
from 9999 or 9997) with and without an earlier run's programs in the folder; a full disk at the k-th program; a
file of a program's name that setupfix did not write, at the top and in a subfolder.  In every case the folder is
byte for byte as it was (programs, manifest, the operator's files) and no temporary file or folder is left.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest

from setupfix.core.atomic import STAGING_PREFIX
from setupfix.core.errors import ExportError
from setupfix.model import load_model
from setupfix.outputs.batch_output import MANIFEST
from setupfix.usecases.batch import run_batch
from setupfix.usecases.requests import CorrectRequest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REQUEST = CorrectRequest(load_model(GUIDE / "model.toml"))


def reports(tmp_path: Path, n: int = 5, sub: str = "", *, reverse: bool = False) -> Path:
    """``cycle_01.csv`` … of the guide-pin sample (``reverse``: cycle_01.csv holds cycle 05's report, …)."""
    d = tmp_path / "in"
    (d / sub).mkdir(parents=True, exist_ok=True)
    for i in range(1, n + 1):
        shutil.copy(GUIDE / f"cycle_0{6 - i if reverse else i}.csv", d / sub / f"cycle_0{i}.csv")
    return d


def snapshot(root: Path) -> dict[str, bytes]:
    """Every file and folder below ``root`` (and around it: its parent's entries), with the files' bytes."""
    if not root.exists():
        return {}
    out = {p.relative_to(root).as_posix(): p.read_bytes() if p.is_file() else b"<dir>" for p in root.rglob("*")}
    return out


def leftovers(tmp_path: Path) -> list[str]:
    return sorted(p.name for p in tmp_path.rglob("*") if p.name.endswith(".tmp") or STAGING_PREFIX in p.name)


@pytest.mark.parametrize(("controller", "first"), [("fanuc", 9997), ("fanuc", 9999)])
@pytest.mark.parametrize("earlier", [False, True])
def test_a_number_past_the_last_writes_no_program(tmp_path: Path, controller: str, first: int, earlier: bool) -> None:
    d = reports(tmp_path)
    out = tmp_path / "programs"
    if earlier:  # an earlier run of two reports: its programs and manifest stay as they were
        two = reports(tmp_path / "two", 2)
        run_batch(REQUEST, two, out, settle=0, controller=controller)
        (out / "operator.nc").write_text("mine\n")
    before = snapshot(out)
    with pytest.raises(ExportError) as info:
        run_batch(REQUEST, d, out, settle=0, controller=controller, program_number=first)
    assert "no program written" in str(info.value)
    assert snapshot(out) == before and (out.exists() == earlier)
    assert leftovers(tmp_path) == []
    # numbered from lower down, the same run writes all five
    s = run_batch(REQUEST, d, out, settle=0, controller=controller, program_number=first - 10)
    assert s.written and len([p for p in snapshot(out) if p.endswith(".nc") and p != "operator.nc"]) == 5


@pytest.mark.parametrize("fail_at", [1, 3, 5])
def test_a_full_disk_writes_no_program(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fail_at: int) -> None:
    d = reports(tmp_path)
    out = tmp_path / "programs"
    run_batch(REQUEST, reports(tmp_path / "old", 3, reverse=True), out, settle=0, controller="fanuc")  # other text
    before = snapshot(out)
    assert len(before) == 4  # three programs and the manifest
    calls = {"n": 0}
    real = os.fsync

    def fsync(fd: int) -> None:
        calls["n"] += 1
        if calls["n"] >= fail_at:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(ExportError) as info:
        run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert "nothing written" in str(info.value) and "disk is full" in str(info.value)
    monkeypatch.setattr(os, "fsync", real)
    assert snapshot(out) == before and leftovers(tmp_path) == []


@pytest.mark.parametrize("sub", ["", "line_A"])
def test_a_file_setupfix_did_not_write_is_never_replaced(tmp_path: Path, sub: str) -> None:
    d = reports(tmp_path, 3, sub)
    out = tmp_path / "programs"
    (out / sub).mkdir(parents=True)
    foreign = out / sub / "cycle_02.csv.nc"
    foreign.write_text("O0002 (THE OPERATOR'S OWN)\n")
    before = snapshot(out)
    with pytest.raises(ExportError) as info:
        run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert str(foreign) in str(info.value) and "nothing written" in str(info.value)
    assert snapshot(out) == before and leftovers(tmp_path) == []
    foreign.unlink()  # moved away: the run writes, and a second run replaces its own programs
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    again = run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert again.written and sorted(p for p in snapshot(out) if p.endswith(".nc")) == [
        f"{sub}/cycle_0{i}.csv.nc".lstrip("/") for i in (1, 2, 3)
    ]
    assert MANIFEST in snapshot(out)


def test_a_killed_runs_staging_folder_is_removed(tmp_path: Path) -> None:
    d = reports(tmp_path, 2)
    out = tmp_path / "programs"
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    dead = out / f"{STAGING_PREFIX}.999999999.abcdef012345.tmp"  # no process has that pid
    (dead / "sub").mkdir(parents=True)
    (dead / "sub" / "half.nc").write_text("%\n")
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert not dead.exists() and leftovers(tmp_path) == []
