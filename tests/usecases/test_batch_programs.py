"""batch --controller: one program per cycle, named uniquely after the report's path; stale programs removed."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from setupfix.model import load_model
from setupfix.outputs.batch_output import MANIFEST
from setupfix.outputs.controllers import NAME_MAX, PROGRAM_NAME_MAX, fit_name, program_path
from setupfix.usecases.batch import run_batch
from setupfix.usecases.requests import CorrectRequest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REQUEST = CorrectRequest(load_model(GUIDE / "model.toml"))


def programs(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file() and p.name != MANIFEST)


def rejected_copy(src: Path, dst: Path) -> None:
    """The report with P1 D1 a whole millimetre off: beyond the reject band (REJECT, no correction)."""
    dst.write_bytes(src.read_bytes().replace(b"24.9691,-0.0309", b"25.9691,0.9691"))


def test_same_stem_in_two_folders_and_two_formats_never_share_a_program(tmp_path: Path) -> None:
    d = tmp_path / "in"
    for line in ("line_A", "line_B"):
        (d / line).mkdir(parents=True)
    shutil.copy(GUIDE / "cycle_03.csv", d / "line_A" / "cycle.csv")  # not cycle 01: its .dmo is the same part
    shutil.copy(GUIDE / "cycle_02.csv", d / "line_B" / "cycle.csv")
    shutil.copy(GUIDE / "cycle_01.dmo", d / "line_B" / "cycle.dmo")
    out = tmp_path / "programs"
    s = run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert s.reports == 3 and s.written
    assert programs(out) == ["line_A/cycle.csv.nc", "line_B/cycle.csv.nc", "line_B/cycle.dmo.nc"]
    a, b = (out / "line_A" / "cycle.csv.nc").read_text(), (out / "line_B" / "cycle.csv.nc").read_text()
    assert a != b  # cycle 03 and cycle 02: different corrections, both kept
    # each equals the program of its report corrected alone
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(GUIDE / "cycle_02.csv", alone / "cycle.csv")
    run_batch(REQUEST, alone, tmp_path / "p2", settle=0, controller="fanuc")
    alone_text = (tmp_path / "p2" / "cycle.csv.nc").read_text()
    assert g10_blocks(alone_text) == g10_blocks(b)  # the number, the title and its plan number (guard) differ


def g10_blocks(program: str) -> list[str]:
    return [line for line in program.splitlines() if " G10 " in line]


def test_a_report_that_no_longer_yields_a_program_leaves_none_behind(tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    for i in (1, 2, 3):
        shutil.copy(GUIDE / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    out = tmp_path / "programs"
    (out / "keep").mkdir(parents=True)
    (out / "keep" / "operator.nc").write_text("mine\n")  # not written by batch: never removed
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert programs(out) == ["cycle_01.csv.nc", "cycle_02.csv.nc", "cycle_03.csv.nc", "keep/operator.nc"]
    rejected_copy(GUIDE / "cycle_01.csv", d / "cycle_01.csv")  # now REJECT
    (d / "cycle_02.csv").write_bytes(b"characteristic,nominal\n")  # now refused (not a report)
    s = run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert s.verdicts["reject"] == 1 and len(s.failed) == 1
    assert programs(out) == ["cycle_03.csv.nc", "keep/operator.nc"]
    shutil.copy(GUIDE / "cycle_01.csv", d / "cycle_01.csv")  # corrected again: its program is back
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert programs(out) == ["cycle_01.csv.nc", "cycle_03.csv.nc", "keep/operator.nc"]


def test_a_name_too_long_for_the_file_system_is_shortened_not_fatal(tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    long_a = "x" * 250 + "_a.csv"[: 255 - 250]  # 255 bytes: the longest name a file may have
    long_b = "x" * 250 + "_b.csv"[: 255 - 250]
    shutil.copy(GUIDE / "cycle_01.csv", d / long_a)
    shutil.copy(GUIDE / "cycle_02.csv", d / long_b)
    out = tmp_path / "programs"
    s = run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert s.reports == 2 and not s.failed and s.written
    names = programs(out)
    assert len(names) == 2 and all(len(os.fsencode(n)) <= PROGRAM_NAME_MAX and n.endswith(".nc") for n in names)
    assert names == sorted(program_path(n, None, "fanuc").as_posix() for n in (long_a, long_b))
    again = run_batch(REQUEST, d, out, settle=0, controller="fanuc")  # deterministic: the same files replaced
    assert again.written and programs(out) == names


def test_fit_name_keeps_short_names_and_cuts_whole_characters() -> None:
    assert fit_name("cycle.csv", ".nc") == "cycle.csv.nc"
    long = "é" * 200  # 400 bytes in UTF-8
    fitted = fit_name(long, ".nc")
    assert len(os.fsencode(fitted)) <= NAME_MAX and fitted.endswith(".nc") and fitted.startswith("é" * 100)
    assert fit_name(long, ".nc") == fitted and fit_name(long + "é", ".nc") != fitted
    assert program_path("r.csv", "P 1", "fanuc") != program_path("r.csv", "P_1", "fanuc")
