"""Every hostile report through ``setupfix parse`` and ``setupfix correct``: one line, exit 1/2, never 3."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from setupfix.cli import main
from tests.hostile.cases import CASES, GUIDE, Case

COMMANDS = {
    "parse": lambda path, out: ["parse", str(path), "--out", str(out)],
    "correct": lambda path, out: ["correct", "--model", str(GUIDE / "model.toml"), str(path), "--offsets", str(out)],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_hostile_report_is_refused_in_one_line(case: Case, command: str, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / case.name
    path.write_bytes(case.make())
    out = tmp_path / "out.csv"
    args = COMMANDS[command](path, out)
    try:
        status = main([*args, *case.options])
    except SystemExit as exc:  # argparse refuses a bad option value
        status = exc.code
    err = capsys.readouterr().err
    assert status in (1, 2), f"exit {status}: {err}"
    assert "internal error" not in err and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("error")]
    assert len(errors) == 1, err
    assert re.search(case.expect, errors[0]), errors[0]
    if status == 1:
        assert case.name in errors[0], errors[0]
    assert not out.exists()
