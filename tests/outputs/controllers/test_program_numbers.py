"""Program numbers: ``--program-number``, the derived default, distinct numbers in a batch, refusals."""

from __future__ import annotations

import itertools
import re
import shutil
from pathlib import Path

import pytest
from conftest import GUIDE_PINS
from multi_axis_rows import fixture_rows

from setupfix.cli import main
from setupfix.core.errors import ExportError
from setupfix.model import load_model
from setupfix.outputs.batch_output import MANIFEST, ProgramNumbers
from setupfix.outputs.controllers import DERIVED_PROGRAMS, derived_program_number, render
from setupfix.usecases.batch import run_batch
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import export, offsets_text
from setupfix.usecases.requests import CorrectOutcome, CorrectRequest

REQUEST = CorrectRequest(load_model(GUIDE_PINS / "model.toml"))


def o_number(program: str) -> int:
    m = re.match(r"%\nO(\d+) \(", program)
    assert m, program[:40]
    return int(m.group(1))


@pytest.mark.parametrize(
    ("name", "n", "word"),
    [("fanuc", 1, "O0001"), ("fanuc", 9999, "O9999"), ("haas", 12, "O0012"), ("haas", 99999, "O99999")],
)
def test_the_o_word(name: str, n: int, word: str) -> None:
    assert (
        render(name, fixture_rows(name, "set", rotation=0.0), program_number=n)
        .split("\n")[1]
        .startswith(word + " (SETUPFIX)")
    )


@pytest.mark.parametrize(
    ("name", "n", "span"),
    [("fanuc", 10000, "1…9999"), ("fanuc", 0, "1…9999"), ("haas", 100000, "1…99999"), ("siemens", 10**8, "1…99999999")],
)
def test_a_number_the_format_cannot_hold_is_refused(name: str, n: int, span: str) -> None:
    with pytest.raises(ExportError, match=f"^{name}: program number {n} outside {span}"):
        render(name, fixture_rows(name, "set", rotation=0.0), program_number=n)


def test_siemens_names_the_program_and_the_tables_have_no_name() -> None:
    text = render("siemens", fixture_rows("siemens", "set"), "t", program_number=42)
    assert text.startswith("%_N_SETUPFIX_42_MPF\n;$PATH=/_N_MPF_DIR\n; SETUPFIX t\n")
    assert not render("siemens", fixture_rows("siemens", "set"), "t").startswith("%")  # no number: no name line
    for name in ("heidenhain", "csv"):  # nothing to name: the text does not change
        rows = fixture_rows(name, "set")
        assert render(name, rows, program_number=10**9) == render(name, rows)


def test_derived_numbers_are_stable_in_range_and_spread() -> None:
    low, high = DERIVED_PROGRAMS
    numbers = [derived_program_number(f"cycle_{i:03d}.csv", "P1") for i in range(500)]
    assert all(low <= n <= high for n in numbers) and len(set(numbers)) > 450
    assert derived_program_number("a.csv", "P1") == derived_program_number("a.csv", "P1")
    assert derived_program_number("a.csv", "P1") != derived_program_number("a.csv", "P2")


@pytest.fixture(scope="module")
def guide() -> CorrectOutcome:
    return correct_report(REQUEST, GUIDE_PINS / "cycle_01.csv")


def test_export_derives_the_number_from_report_and_part_or_takes_the_given_one(
    guide: CorrectOutcome, tmp_path: Path
) -> None:
    cycle = guide.cycles[0]
    done = export(guide.cycles, str(tmp_path / "a.nc"), controller="fanuc")
    assert o_number(done.text) == done.program_number == derived_program_number(cycle.part.report, cycle.part.part)
    given = export(guide.cycles, str(tmp_path / "b.nc"), controller="fanuc", program_number=77)
    assert o_number(given.text) == given.program_number == 77
    assert given.text.split("\n", 2)[2] == offsets_text(guide.cycles, "fanuc").split("\n", 2)[2]
    with pytest.raises(ExportError, match="fanuc: program number 12000 outside"):
        export(guide.cycles, str(tmp_path / "c.nc"), controller="fanuc", program_number=12000)
    assert not (tmp_path / "c.nc").exists()
    assert export(guide.cycles, str(tmp_path / "d.csv")).program_number is None


def test_batch_numbers_are_distinct_in_a_run_and_follow_the_path() -> None:
    numbers = ProgramNumbers("fanuc")
    # two paths with the same derived number: the second gets the next free one
    seen: dict[int, str] = {}
    for i in itertools.count():
        name = f"r{i}.csv.nc"
        n = derived_program_number(name)
        if n in seen:
            first, second = seen[n], name
            break
        seen[n] = name
    assert numbers.take(first) == n and numbers.take(second) == (n + 1 if n < DERIVED_PROGRAMS[1] else 1000)
    assert ProgramNumbers("fanuc").take(second) == n  # alone, it gets its own
    counted = ProgramNumbers("haas", 9998)
    assert [counted.take(f"{i}.nc") for i in range(3)] == [9998, 9999, 10000]  # Haas holds five digits
    full = ProgramNumbers("fanuc", 9999)
    full.take("a.nc")
    with pytest.raises(ExportError, match=r"program number 10000 outside 1…9999.*program 2 of the run \(b\.nc\)"):
        full.take("b.nc")
    assert ProgramNumbers("heidenhain", 5).take("x.txt") is None


def test_batch_writes_distinct_numbers_stable_run_after_run(tmp_path: Path) -> None:
    d = tmp_path / "in"
    d.mkdir()
    for name in ("cycle_01.csv", "cycle_02.csv", "cycle_03.csv"):
        shutil.copy(GUIDE_PINS / name, d / name)
    out = tmp_path / "programs"
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    texts = {p.name: p.read_text() for p in sorted(out.glob("*.nc"))}
    numbers = [o_number(t) for t in texts.values()]
    assert len(set(numbers)) == 3 and numbers == [derived_program_number(n) for n in texts]  # no collision here
    run_batch(REQUEST, d, out, settle=0, controller="fanuc")
    assert {p.name: p.read_text() for p in out.glob("*.nc")} == texts
    run_batch(REQUEST, d, tmp_path / "given", settle=0, controller="fanuc", program_number=500)
    given = sorted(o_number(p.read_text()) for p in (tmp_path / "given").glob("*.nc"))
    assert given == [500, 501, 502] and (tmp_path / "given" / MANIFEST).exists()
    first = (tmp_path / "given" / "cycle_01.csv.nc").read_text()
    assert o_number(first) == 500 and "(SETUPFIX CYCLE_01.CSV" in first


def test_cli_refuses_a_number_the_controller_cannot_hold_before_any_work(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    model, report = str(GUIDE_PINS / "model.toml"), str(GUIDE_PINS / "cycle_01.csv")
    code = main(
        [
            "correct",
            "--model",
            model,
            "--offsets",
            str(tmp_path / "o.nc"),
            "--controller",
            "fanuc",
            "--program-number",
            "10000",
            report,
        ]
    )
    err = capsys.readouterr().err
    assert code != 0 and "fanuc: program number 10000 outside 1…9999" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.nc").exists()
    code = main(
        [
            "batch",
            "--model",
            model,
            "--out",
            str(tmp_path / "p"),
            "--controller",
            "haas",
            "--program-number",
            "100000",
            "--settle",
            "0",
            str(Path(report).parent),
        ]
    )
    assert code != 0 and "haas: program number 100000 outside 1…99999" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()
    code = main(
        [
            "correct",
            "--model",
            model,
            "--offsets",
            str(tmp_path / "o.nc"),
            "--controller",
            "fanuc",
            "--program-number",
            "321",
            report,
        ]
    )
    assert code == 0 and o_number((tmp_path / "o.nc").read_text()) == 321
