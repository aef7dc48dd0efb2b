"""Every hostile report through every command that reads reports: one line, exit 1/2, never 3.

``parse``, ``correct`` and ``history import`` take every case; the commands whose options
differ (``compare``, ``model init``, ``model check``, ``diagnose``) take the cases that need no
extra option; the TUI's session (``open_report``) takes every case too.  A file's name is
checked as the user sees it: printable (:func:`parsers.names.visible_name`), on one line.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from hostile.cases import CASES, GUIDE, Case
from parsers.names import visible_name
from setupfix.cli import main
from setupfix.core.errors import SetupfixError

if TYPE_CHECKING:
    from setupfix.usecases.requests import CorrectRequest

MODEL = str(GUIDE / "model.toml")
COMMANDS = {
    "parse": lambda path, out: ["parse", str(path), "--out", str(out)],
    "correct": lambda path, out: ["correct", "--model", MODEL, str(path), "--offsets", str(out)],
    "compare": lambda path, out: ["compare", "--model", MODEL, "--trials", "1", "--plot", str(out) + ".png", str(path)],
    "model-init": lambda path, out: ["model", "init", str(path), "-o", str(out)],
    "model-check": lambda path, out: ["model", "check", MODEL, str(path)],
    "diagnose": lambda path, out: ["diagnose", "--model", MODEL, "--augment", str(out), str(path)],
    "history-import": lambda path, out: ["history", "import", "--db", str(out) + ".db", str(path)],
}
#: Commands that take every case (the cases' extra options are theirs).
ALL_CASES = ("parse", "correct", "history-import")
PAIRS = [(command, case) for command in sorted(COMMANDS) for case in CASES if command in ALL_CASES or not case.options]


def case_id(value: object) -> str:
    return value if isinstance(value, str) else visible_name(value.name)  # type: ignore[attr-defined]


@pytest.mark.parametrize(("command", "case"), PAIRS, ids=case_id)
def test_hostile_report_is_refused_in_one_line(
    case: Case, command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / case.name
    path.write_bytes(case.make())
    out = tmp_path / "out.csv"
    args = COMMANDS[command](path, out)
    try:
        status: str | int | None = main([*args, *case.options])
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
    assert not out.exists() and not Path(str(out) + ".png").exists()
    if command == "history-import" and Path(str(out) + ".db").exists():  # nothing half-written in the store
        from setupfix.store import open_store

        with open_store(str(out) + ".db") as store:
            assert store.reports() == []


@pytest.mark.parametrize("case", [c for c in CASES if not c.options], ids=case_id)
def test_the_tui_session_refuses_in_one_line(case: Case, tmp_path: Path) -> None:
    from setupfix.tui.session import open_report

    path = tmp_path / case.name
    path.write_bytes(case.make())
    with pytest.raises(SetupfixError) as caught:
        open_report(REQUEST, path)
    line = str(caught.value)
    assert "\n" not in line and line.isprintable() and visible_name(case.name) in line
    assert re.search(case.expect, line), line


def _request() -> CorrectRequest:
    from setupfix.model import load_model
    from setupfix.usecases.requests import CorrectRequest

    return CorrectRequest(load_model(MODEL))


REQUEST = _request()
