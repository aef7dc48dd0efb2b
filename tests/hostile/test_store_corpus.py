"""Every hostile report through the commands that store reports: one line, exit 1/2, the store unchanged.

``history import`` and ``batch --store`` take the corpus of :mod:`tests.hostile.cases` into a store
that already holds a report: the import is refused naming the file and stores nothing; the batch
names the file among its failures, corrects the good report beside it and stores only that one.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from hostile.cases import CASES, GUIDE, Case
from parsers.names import visible_name
from setupfix.cli import main
from setupfix.store import open_store

MODEL = str(GUIDE / "model.toml")


def _held(db: Path) -> tuple[int, int, int]:
    with open_store(db) as store:
        return len(store.reports()), len(store.measurements()), len(store.recommendations())


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_history_import_refuses_a_hostile_report_in_one_line_and_stores_nothing(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "h.db"
    assert main(["history", "import", "--db", str(db), str(GUIDE / "cycle_01.csv")]) == 0
    before = _held(db)
    path = tmp_path / case.name
    path.write_bytes(case.make())
    capsys.readouterr()
    try:
        status: str | int | None = main(
            ["history", "import", "--db", str(db), str(path), str(GUIDE / "cycle_02.csv"), *case.options]
        )
    except SystemExit as exc:  # argparse refuses a bad option value
        status = exc.code
    err = capsys.readouterr().err
    assert status in (1, 2), f"exit {status}: {err}"
    assert "internal error" not in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("error")]
    assert len(errors) == 1, err
    assert re.search(case.expect, errors[0]), errors[0]
    if status == 1:
        assert visible_name(case.name) in errors[0], errors[0]
    assert _held(db) == before  # one transaction: the good report beside it is not stored either


@pytest.mark.parametrize("case", [c for c in CASES if not c.options], ids=lambda c: c.name)
def test_batch_store_names_a_hostile_report_and_stores_only_the_good_one(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "reports"
    folder.mkdir()
    shutil.copy(GUIDE / "cycle_02.csv", folder / "cycle_02.csv")
    (folder / case.name).write_bytes(case.make())
    db, out = tmp_path / "h.db", tmp_path / "out.csv"
    capsys.readouterr()
    status = main(
        [
            "batch",
            str(folder),
            "--model",
            MODEL,
            "--out",
            str(out),
            "--store",
            str(db),
            "--settle",
            "0",
            "--workers",
            "1",
        ]
    )
    err = capsys.readouterr().err
    assert "internal error" not in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("error")]
    if status == 0:  # a case the folder listing leaves out (not a report by its name): nothing to name
        assert errors == []
    else:
        assert status == 4 and len(errors) == 1 and visible_name(case.name) in errors[0], err
    reports, rows, recs = _held(db)
    assert (reports, recs) == (1, 1) and rows == 28  # cycle_02 alone, whole
    assert "cycle_02.csv" in out.read_text()
