"""Good reports under hostile file names through every command: no crash, names escaped in every output.

The names (:data:`tests.hostile.cases.HOSTILE_NAMES`) start with a formula character or
hold a tab, CR, line feed or bytes that are not UTF-8.  Every output (offsets CSV,
canonical CSV, program, JSON, history store, stderr) must be valid UTF-8 text with the
name in its printable form (:func:`parsers.names.visible_name`), every CSV cell through
:func:`setupfix.outputs.writers.csv_cell`, every CSV reading back row for row with the
project's reader and pandas.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
from pathlib import Path

import pandas as pd
import pytest

import parsers
from hostile.cases import GUIDE, HOSTILE_NAMES
from parsers.names import visible_name
from setupfix.cli import main
from setupfix.outputs.writers import csv_cell

MODEL = str(GUIDE / "model.toml")
REPORTS = sorted(GUIDE.glob("cycle_0*.csv"))


def good_report(i: int) -> bytes:
    """A distinct, correct report (cycle i, its time shifted so no two are the same content)."""
    data = REPORTS[i % len(REPORTS)].read_bytes()
    return data if i < len(REPORTS) else data.replace(b"08:00:00", f"08:{i:02d}:00".encode())


def write_named(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, name in enumerate(HOSTILE_NAMES):
        path = folder / name
        path.write_bytes(good_report(i))
        paths.append(path)
    return paths


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "internal error" not in err and "Traceback" not in err, err
    assert all(line.isprintable() for line in err.splitlines()), err
    return code, out, err


def csv_rows(path: Path) -> list[dict[str, str]]:
    text = path.read_bytes().decode("utf-8")
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(pd.read_csv(path, dtype=str, keep_default_na=False)) == len(rows) == text.count("\n") - 1
    return rows


@pytest.mark.slow
@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=visible_name)
def test_one_report_commands(name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_named(tmp_path / "in")[HOSTILE_NAMES.index(name)]
    shown = visible_name(name)
    code, _, _ = run(capsys, "correct", "--model", MODEL, str(path), "--offsets", str(tmp_path / "o.csv"))
    assert code == 0 and {r["report"] for r in csv_rows(tmp_path / "o.csv")} == {csv_cell(shown)}
    code, out, _ = run(capsys, "correct", "--model", MODEL, str(path), "--json")
    assert code == 0 and json.loads(out)["report"] == shown
    code, _, _ = run(
        capsys, "correct", "--model", MODEL, str(path), "--controller", "fanuc", "--offsets", str(tmp_path / "o.nc")
    )
    program = (tmp_path / "o.nc").read_bytes().decode("utf-8").split("\n")
    (tmp_path / "plain.csv").write_bytes(path.read_bytes())
    run(
        capsys,
        "correct",
        "--model",
        MODEL,
        str(tmp_path / "plain.csv"),
        "--controller",
        "fanuc",
        "--offsets",
        str(tmp_path / "plain.nc"),
    )
    plain = (tmp_path / "plain.nc").read_text().split("\n")
    # no line break from the name; the plan number of the add guard follows the title, so it is masked
    assert code == 0 and len(program) == len(plain) and _unplanned(program[2:]) == _unplanned(plain[2:])
    code, _, _ = run(capsys, "model", "check", MODEL, str(path))
    assert code == 0
    code, out, _ = run(capsys, "compare", "--model", MODEL, "--trials", "1", "--json", str(path))
    assert code == 0 and json.loads(out)


@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=visible_name)
def test_the_tui_session_opens_exports_and_records(name: str, tmp_path: Path) -> None:
    from setupfix.model import load_model
    from setupfix.store import open_store
    from setupfix.tui.session import export_cycles, open_report, record_applied
    from setupfix.usecases.export import export
    from setupfix.usecases.requests import CorrectRequest

    path = write_named(tmp_path / "in")[HOSTILE_NAMES.index(name)]
    opened = open_report(CorrectRequest(load_model(MODEL)), path)
    assert opened.report == visible_name(str(path)) and opened.corrections
    target = tmp_path / name  # an export named like the report, beside it
    exported = export(export_cycles(opened, "csv"), str(target))
    assert {r["report"] for r in csv_rows(target)} == {csv_cell(visible_name(name))}
    program = export(export_cycles(opened, "fanuc", 0), str(tmp_path / "p.nc"), controller="fanuc")
    assert program.text.isascii()
    db = tmp_path / "h.db"
    assert record_applied(db, exported, opened.corrections) > 0
    with open_store(db) as store:
        applied = [r.inputs for r in store.recommendations()]
    assert applied[0]["report"] == visible_name(name) and applied[0]["export"]["target"] == visible_name(str(target))


@pytest.mark.slow
def test_many_report_commands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    paths = [str(p) for p in write_named(tmp_path / "in")]
    shown = {visible_name(n) for n in HOSTILE_NAMES}
    code, _, _ = run(capsys, "parse", *paths, "--out", str(tmp_path / "m.csv"))
    assert code == 0
    assert {r["report"] for r in csv_rows(tmp_path / "m.csv")} == {csv_cell(n) for n in shown}
    back = parsers.read_report(tmp_path / "m.csv").table  # the project's reader removes the formula prefix
    assert set(back["report"]) == shown
    code, _, _ = run(
        capsys, "batch", str(tmp_path / "in"), "--model", MODEL, "--out", str(tmp_path / "b.csv"), "--settle", "0"
    )
    assert code == 0 and {r["report"] for r in csv_rows(tmp_path / "b.csv")} == {csv_cell(n) for n in shown}
    code, _, _ = run(capsys, "history", "import", "--db", str(tmp_path / "h.db"), *paths)
    assert code == 0
    from setupfix.store import open_store

    with open_store(tmp_path / "h.db") as store:
        assert {r.name for r in store.reports()} == shown
    code, out, _ = run(capsys, "diagnose", "--model", MODEL, "--no-walk", "--json", *paths)
    assert code == 0 and json.loads(out)
    code, _, _ = run(capsys, "model", "init", *paths, "-o", str(tmp_path / "model.toml"))
    assert code == 0 and (tmp_path / "model.toml").read_bytes().decode("utf-8")
    assert os.listdir(tmp_path / "in") == os.listdir(tmp_path / "in")  # inputs untouched


def _unplanned(lines: list[str]) -> list[str]:
    """Program lines with the add guard's plan number masked (it follows the program's title)."""
    return [re.sub(r"(PLAN |EQ |#549=)\d+", r"\g<1>N", line) for line in lines]
