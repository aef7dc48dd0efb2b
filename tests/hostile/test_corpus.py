"""Every hostile report through every command that reads reports: one line, exit 1/2, never 3.

``parse`` and ``correct`` take every case; the commands whose options differ (``compare``,
``model init``, ``model check``, ``diagnose``) take the cases that need no extra option.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from setupfix.cli import main
from tests.hostile.cases import CASES, GUIDE, Case

MODEL = str(GUIDE / "model.toml")
COMMANDS = {
    "parse": lambda path, out: ["parse", str(path), "--out", str(out)],
    "correct": lambda path, out: ["correct", "--model", MODEL, str(path), "--offsets", str(out)],
    "compare": lambda path, out: ["compare", "--model", MODEL, "--trials", "1", "--plot", str(out) + ".png",
                                  str(path)],
    "model-init": lambda path, out: ["model", "init", str(path), "-o", str(out)],
    "model-check": lambda path, out: ["model", "check", MODEL, str(path)],
    "diagnose": lambda path, out: ["diagnose", "--model", MODEL, "--augment", str(out), str(path)],
}
#: Commands that take every case (the cases' extra options are theirs).
ALL_CASES = ("parse", "correct")
PAIRS = [(command, case) for command in sorted(COMMANDS) for case in CASES
         if command in ALL_CASES or not case.options]


@pytest.mark.parametrize(("command", "case"), PAIRS, ids=lambda v: v if isinstance(v, str) else v.name)
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
    assert not out.exists() and not Path(str(out) + ".png").exists()
