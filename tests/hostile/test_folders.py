"""The whole corpus as one folder (with links, a loop, an unreadable sub-folder) through the folder commands.

``batch``: every hostile file is one ``error:`` line naming it (printable), the good report's
rows are written, exit 4; ``parse`` and ``history import`` of the folder name every file they
leave out and write only what they read.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from hostile.cases import CASES, GUIDE, write_corpus
from parsers.names import visible_name
from setupfix.cli import main

MODEL = str(GUIDE / "model.toml")


def corpus_folder(tmp_path: Path) -> Path:
    d = tmp_path / "corpus"
    write_corpus(d)
    shutil.copy(GUIDE / "cycle_01.csv", d / "good.csv")
    shutil.copy(GUIDE / "cycle_02.csv", tmp_path / "outside.csv")
    os.symlink(tmp_path / "outside.csv", d / "linked.csv")
    os.symlink(d, d / "loop")
    os.symlink(d / "nowhere.csv", d / "broken.csv")
    if os.geteuid() != 0:
        (d / "locked").mkdir()
        (d / "locked").chmod(0)
    return d


def unlock(d: Path) -> None:
    if (d / "locked").exists():
        (d / "locked").chmod(0o755)


def test_batch_names_every_hostile_file_and_writes_the_good_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = corpus_folder(tmp_path)
    try:
        code = main(["batch", str(d), "--model", MODEL, "--out", str(tmp_path / "o.csv"), "--settle", "0"])
    finally:
        unlock(d)
    err = capsys.readouterr().err
    assert code == 4 and "internal error" not in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    for case in CASES:
        if not case.options:  # the punycode case needs its --encoding: in a batch it is a plain report
            assert sum(visible_name(case.name) in line for line in errors) >= 1, case.name
    assert any(line.endswith("loop: link to a folder: not followed") for line in errors)
    assert any(line.endswith("broken.csv: broken link") for line in errors)
    if os.geteuid() != 0:
        assert any(line.endswith("locked: cannot list folder: permission denied") for line in errors)
    assert f"warning: {d / 'linked.csv'}: symbolic link to" in err
    assert not any(len(p := line.split(": ")) > 2 and p[1] == p[2] for line in err.splitlines())  # path said once
    reports = {line.split(",")[0] for line in (tmp_path / "o.csv").read_text().splitlines()[1:]}
    assert {"good.csv", "linked.csv"} <= reports


def test_parse_and_history_import_of_the_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = corpus_folder(tmp_path)
    try:
        parsed = main(["parse", str(d), "--out", str(tmp_path / "m.csv")])
        err = capsys.readouterr().err
        imported = main(["history", "import", "--db", str(tmp_path / "h.db"), str(d)])
        refused = capsys.readouterr().err
    finally:
        unlock(d)
    assert parsed == 4 and "internal error" not in err and "Traceback" not in err
    assert all(line.isprintable() for line in err.splitlines())
    assert "loop: link to a folder: not followed" in err and "broken.csv: broken link" in err
    for case in CASES:
        if not case.options:
            assert visible_name(case.name) in err, case.name  # parse says every file it leaves out
    # history import is one transaction: the first bad report refuses the whole import, in one line
    assert imported == 1 and [line.startswith("error:") for line in refused.splitlines()] == [True]
    from setupfix.store import open_store

    with open_store(tmp_path / "h.db") as store:
        assert store.reports() == []


@pytest.mark.parametrize("command", ["diagnose", "model-init"])
def test_series_commands_on_the_folder(command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = corpus_folder(tmp_path)
    args = (
        ["diagnose", "--model", MODEL, "--no-walk", str(d)]
        if command == "diagnose"
        else ["model", "init", str(d), "-o", str(tmp_path / "m.toml")]
    )
    try:
        code = main(args)
    finally:
        unlock(d)
    err = capsys.readouterr().err
    assert code in (0, 1, 4) and "internal error" not in err and "Traceback" not in err, err
    assert all(line.isprintable() for line in err.splitlines())
