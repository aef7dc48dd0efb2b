"""batch on hostile names and a changing tree: names escaped in the CSV, said, never a crash or a silent skip."""

from __future__ import annotations

import csv
import io
import os
import shutil
from pathlib import Path

import pandas as pd
import pytest

from setupfix.cli import main
from setupfix.model import load_model
from setupfix.usecases.batch import run_batch
from setupfix.usecases.requests import CorrectRequest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
MODEL = GUIDE / "model.toml"
REQUEST = CorrectRequest(load_model(MODEL))

#: File names (bytes) and the report cell the offsets CSV must hold for each.
NAMES = {
    b"=HYPERLINK(1).csv": "'=HYPERLINK(1).csv",
    b"+sum.csv": "'+sum.csv",
    b"-minus.csv": "'-minus.csv",
    b"@at.csv": "'@at.csv",
    b"\tTab.csv": "\\tTab.csv",
    b"\rcr_first.csv": "\\rcr_first.csv",
    b"cr\rinside.csv": "cr\\rinside.csv",
    b"line\nbreak.csv": "line\\nbreak.csv",
    b"bad\xffname.csv": "bad\\xffname.csv",
}


def hostile_folder(tmp_path: Path) -> Path:
    d = tmp_path / "in"
    d.mkdir()
    reports = sorted(GUIDE.glob("cycle_0*.csv"))
    for i, name in enumerate(NAMES):  # distinct content: no report is skipped as a copy of another
        data = reports[i % len(reports)].read_bytes()
        with open(os.fsencode(d) + b"/" + name, "wb") as fh:
            fh.write(data if i < len(reports) else data.replace(b"08:00:00", f"08:{i:02d}:00".encode()))
    return d


def check_offsets_csv(path: Path, expected_reports: set[str]) -> None:
    text = path.read_text(encoding="utf-8")  # UTF-8 throughout: nothing to crash on
    lines = text.split("\n")
    assert all("\r" not in line for line in lines)  # one row per line
    rows = list(csv.DictReader(io.StringIO(text)))
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    assert len(rows) == len(frame) == len(lines) - 2 and {r["report"] for r in rows} == expected_reports
    assert frame["report"].tolist() == [r["report"] for r in rows]
    assert pd.to_numeric(frame["delta"]).notna().all()  # numbers stay numbers (a negative one unescaped)


def test_batch_writes_every_hostile_name_escaped(tmp_path: Path) -> None:
    d = hostile_folder(tmp_path)
    s = run_batch(REQUEST, d, tmp_path / "o.csv", settle=0)
    assert s.reports == len(NAMES) and not s.failed and not s.skipped
    check_offsets_csv(tmp_path / "o.csv", set(NAMES.values()))
    assert all(f.isprintable() for f, _ in s.failed + s.skipped)


@pytest.mark.slow
def test_batch_and_correct_commands_escape_names(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = hostile_folder(tmp_path)
    assert main(["batch", str(d), "--model", str(MODEL), "--out", str(tmp_path / "b.csv"), "--settle", "0"]) == 0
    check_offsets_csv(tmp_path / "b.csv", set(NAMES.values()))
    err = capsys.readouterr().err
    assert "internal error" not in err and "bad\\xffname.csv: apply" in err
    for i, (name, cell) in enumerate(NAMES.items()):
        out = tmp_path / f"c{i}.csv"
        path = os.fsdecode(os.fsencode(d) + b"/" + name)
        assert main(["correct", "--model", str(MODEL), path, "--offsets", str(out)]) == 0, capsys.readouterr().err
        check_offsets_csv(out, {cell})
        assert main(["correct", "--model", str(MODEL), path, "--json"]) == 0
        assert "internal error" not in capsys.readouterr().err


def test_a_file_removed_between_listing_and_reading_is_a_failed_line(tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    for i in (1, 2, 3):
        shutil.copy(GUIDE / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    gone = d / "cycle_02.csv"

    def remove_next(done: int, total: int, outcome: object) -> None:  # runs after report 1, before report 2 is read
        if done == 1:
            gone.unlink()

    s = run_batch(REQUEST, d, tmp_path / "o.csv", settle=0, progress=remove_next)
    assert s.reports == 2 and s.written
    assert s.failed == ((str(gone), f"{gone}: renamed or removed after the folder was listed: not read"),)


def test_links_and_unreadable_folders_are_said(tmp_path: Path) -> None:
    d = tmp_path / "in"
    (d / "sub").mkdir(parents=True)
    shutil.copy(GUIDE / "cycle_01.csv", d / "cycle_01.csv")
    shutil.copy(GUIDE / "cycle_02.csv", tmp_path / "elsewhere.csv")
    os.symlink(tmp_path / "elsewhere.csv", d / "linked.csv")  # read, said
    os.symlink(d / "cycle_01.csv", d / "sub" / "again.csv")  # the same report: read once, under its own name
    os.symlink(d, d / "sub" / "loop")  # a folder link: never followed
    s = run_batch(REQUEST, d, tmp_path / "o.csv", settle=0)
    assert s.reports == 2
    assert [(f, str(n)) for f, n in s.notes if "symbolic link" in str(n)] == [
        (str(d / "linked.csv"), f"symbolic link to {(tmp_path / 'elsewhere.csv').resolve()}: read as a report")
    ]
    assert (str(d / "sub" / "loop"), "link to a folder: not followed") in s.failed


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads a chmod 000 folder")
def test_an_unreadable_sub_folder_is_a_failed_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "in"
    (d / "locked").mkdir(parents=True)
    shutil.copy(GUIDE / "cycle_01.csv", d / "cycle_01.csv")
    (d / "locked").chmod(0)
    try:
        code = main(["batch", str(d), "--model", str(MODEL), "--out", str(tmp_path / "o.csv"), "--settle", "0"])
    finally:
        (d / "locked").chmod(0o755)
    assert code == 4 and f"{d / 'locked'}: cannot list folder: permission denied" in capsys.readouterr().err
