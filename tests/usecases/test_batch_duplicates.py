"""Issue 37 item 13: batch corrects one measurement once, whatever files bring it.

The issue's case is ``batch sample_reports/guide_pins``: the ``.csv``, ``.dmo`` and ``.qif`` of cycle 01
gave three APPLY sets.  Variants here: the DMIS and QIF without the CSV, a CRLF copy whose part name
differs in case and spacing and lacks one row, a report of two parts of which one repeats, programs,
and a history store that already holds the measurement from another file.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setupfix.model import load_model
from setupfix.store import open_store
from setupfix.usecases.batch import run_batch
from setupfix.usecases.requests import CorrectRequest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
REQUEST = CorrectRequest(load_model(GUIDE / "model.toml"))


def crlf_copy(source: Path, target: Path, part: str) -> Path:
    """``source`` with CRLF line ends, its part renamed ``part`` and its second row left out."""
    lines = source.read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("part")
    rows = [",".join(part if j == k else c for j, c in enumerate(line.split(","))) for line in lines[1:]]
    target.write_bytes(("\r\n".join([lines[0], rows[0], *rows[2:]]) + "\r\n").encode())
    return target


def shop(tmp_path: Path) -> Path:
    d = tmp_path / "reports"
    (d / "line_b").mkdir(parents=True)
    shutil.copy(GUIDE / "cycle_01.dmo", d / "a_cycle_01.dmo")
    shutil.copy(GUIDE / "cycle_01.qif", d / "line_b" / "cycle_01.qif")
    shutil.copy(GUIDE / "cycle_02.csv", d / "b_cycle_02.csv")
    crlf_copy(GUIDE / "cycle_02.csv", d / "line_b" / "again_02.csv", "CYCLE  02 ")
    shutil.copy(GUIDE / "cycle_03.csv", d / "c_cycle_03.csv")
    return d


def test_one_measurement_in_several_files_is_corrected_once_and_the_copies_are_named(tmp_path: Path) -> None:
    d = shop(tmp_path)
    out = tmp_path / "offsets.csv"
    s = run_batch(REQUEST, d, out, settle=0)
    assert (s.reports, s.parts, s.verdicts["apply"]) == (3, 3, 3)
    assert [(Path(f).relative_to(d).as_posix(), r) for f, r in s.skipped] == [
        ("line_b/again_02.csv", f"same measurement as {d / 'b_cycle_02.csv'} (part 'cycle 02')"),
        ("line_b/cycle_01.qif", f"same measurement as {d / 'a_cycle_01.dmo'} (part 'cycle 01')"),
    ]
    lines = out.read_text().splitlines()[1:]
    assert sorted({line.split(",")[0] for line in lines}) == ["a_cycle_01.dmo", "b_cycle_02.csv", "c_cycle_03.csv"]
    # incremental programs: one per measurement, never a second one for a copy
    s = run_batch(REQUEST, d, tmp_path / "programs", settle=0, controller="fanuc")
    assert s.reports == 3
    assert sorted(p.name for p in (tmp_path / "programs").rglob("*.nc")) == [
        "a_cycle_01.dmo.nc",
        "b_cycle_02.csv.nc",
        "c_cycle_03.csv.nc",
    ]


def test_a_report_whose_one_part_repeats_keeps_its_other_part(tmp_path: Path) -> None:
    d = tmp_path / "reports"
    d.mkdir()
    shutil.copy(GUIDE / "cycle_02.csv", d / "a.csv")
    two = (GUIDE / "cycle_04.csv").read_text().splitlines()
    two += (GUIDE / "cycle_02.csv").read_text().replace("cycle 02", "Cycle 02").splitlines()[1:]
    (d / "b.csv").write_text("\n".join(two) + "\n")
    s = run_batch(REQUEST, d, tmp_path / "offsets.csv", settle=0)
    assert (s.reports, s.parts) == (2, 2) and not s.skipped
    said = [(Path(f).name, n.message) for f, n in s.notes if n.kind == "duplicate"]
    assert said == [
        ("b.csv", f"part 'Cycle 02' is the same measurement as {d / 'a.csv'} (part 'cycle 02'): not corrected again")
    ]
    rows = [line.split(",") for line in (tmp_path / "offsets.csv").read_text().splitlines()[1:]]
    assert sorted({(r[0], r[1]) for r in rows}) == [("a.csv", "cycle 02"), ("b.csv", "cycle 04")]


def test_a_store_that_holds_the_measurement_from_another_file_skips_the_copy(tmp_path: Path) -> None:
    d = tmp_path / "reports"
    d.mkdir()
    shutil.copy(GUIDE / "cycle_02.csv", d / "cycle_02.csv")
    with open_store(tmp_path / "h.db") as store:
        first = run_batch(REQUEST, d, tmp_path / "o1.csv", settle=0, store=store)
        crlf_copy(GUIDE / "cycle_02.csv", d / "late_copy.csv", "cycle 02")
        shutil.copy(GUIDE / "cycle_03.csv", d / "cycle_03.csv")
        second = run_batch(REQUEST, d, tmp_path / "o2.csv", settle=0, store=store)
        assert sorted(r.name for r in store.reports()) == ["cycle_02.csv", "cycle_03.csv"]
        forced = run_batch(REQUEST, d, tmp_path / "o3.csv", settle=0, store=store, force=True)
    assert first.reports == 1 and second.reports == 1
    assert [(Path(f).name, r) for f, r in second.skipped if "already processed" not in r] == [
        ("late_copy.csv", "same measurement as cycle_02.csv in the history store (part 'cycle 02')")
    ]
    # forced, every report is corrected again, and the copy still once
    assert forced.reports == 2
    assert [(Path(f).name, r) for f, r in forced.skipped] == [
        ("late_copy.csv", f"same measurement as {d / 'cycle_02.csv'} (part 'cycle 02')")
    ]
