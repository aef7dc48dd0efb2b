"""The TUI's "send to machine" (w) driven by Pilot against the OPC UA test control (``tests/opcua_control.py``).

The dry-run diff, the second explicit question, the guarded write of ``machine write --apply`` (the one
use case), the read-back or the refusal in one line, the operator in the audit; Enter alone never sends.
The control holds ``sample_reports/controllers``' registers (G54/G55 Z, H5/H12 wear, mm, increment 0.0001).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from conftest import SAMPLES
from textual.widgets import DataTable, Static
from tui.conftest import run, settle

from setupfix.store import open_store
from setupfix.tui.screens import ConfirmScreen
from setupfix.tui.screens.send import SendScreen

if TYPE_CHECKING:
    from opcua_control import TestControl

    from setupfix.tui.app import SetupfixApp

pytest.importorskip("asyncua")
pytestmark = pytest.mark.slow  # an OPC UA server and an app start (seconds)

SAMPLE = SAMPLES / "controllers"
VALUES = {"G54.Z": -412.53, "G55.Z": -412.487, "H5": -0.012, "H12": 0.0035}
MAP = {"G54": {"Z": "G54.Z"}, "G55": {"Z": "G55.Z"}, "H5": {"length": "H5"}, "H12": {"length": "H12"}}
#: What ``correct`` gives on the sample report with these values (tests/links/test_opcua_write.py shows it).
CHANGES = {"G54.Z": -0.023, "G55.Z": 0.022, "H5": -0.009, "H12": 0.002}


@pytest.fixture(scope="module")
def server() -> Iterator[TestControl]:
    from opcua_control import ControlSpec, running_control

    with running_control(ControlSpec(dict(VALUES), increment=0.0001)) as control:
        yield control


@pytest.fixture
def control(server: TestControl) -> TestControl:
    server.reset()
    return server


def make_app(tmp_path: Path, control: TestControl, *, link: bool = True) -> SetupfixApp:
    from opcua_control import link_toml

    from setupfix.tui.app import SetupfixApp
    from setupfix.tui.state import Inputs

    path = tmp_path / "link.toml"
    path.write_text(link_toml(control, MAP, machine="mc-07"))
    return SetupfixApp(
        Inputs(
            model=SAMPLE / "model.toml",
            report=SAMPLE / "report.csv",
            db=str(tmp_path / "history.sqlite"),
            operator="anna",
            link=path if link else None,
            offsets=str(tmp_path / "offsets.csv"),
        )
    )


def notes(app: SetupfixApp) -> list[tuple[str, str]]:
    return [(n.title, n.message) for n in app._notifications]


def table_rows(screen: Any) -> list[list[str]]:
    table = screen.query_one("#send-table", DataTable)
    return [[str(c) for c in table.get_row(k)] for k in table.rows]


def test_send_shows_the_diff_asks_twice_writes_and_records_the_operator(tmp_path: Path, control: TestControl) -> None:
    async def scenario() -> None:
        app = make_app(tmp_path, control)
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            assert app.state.current() is not None, notes(app)
            # the current offsets were read from the control: the plan records them
            assert app.state.opened is not None and app.state.opened.current is not None
            assert app.state.opened.current.snapshot is not None
            await pilot.press("w")
            await settle(pilot)
            screen = app.screen
            assert isinstance(screen, SendScreen), notes(app)
            assert table_rows(screen) == [
                ["G54", "Z", "-412.5300", "-0.0230", "-412.5530"],
                ["G55", "Z", "-412.4870", "+0.0220", "-412.4650"],
                ["H5", "length", "-0.0120", "-0.0090", "-0.0210"],
                ["H12", "length", "0.0035", "+0.0020", "0.0055"],
            ]
            # Enter alone never sends: Cancel is focused
            await pilot.press("enter")
            await settle(pilot)
            assert not isinstance(app.screen, SendScreen) and control.values["G54.Z"] == VALUES["G54.Z"]
            assert ("send to machine", "nothing sent") in notes(app)

            await pilot.press("w")
            await settle(pilot)
            await pilot.press("s")
            await pilot.pause()
            confirm = app.screen
            assert isinstance(confirm, ConfirmScreen)
            question = str(confirm.query_one("#confirm-question", Static).render())
            assert "Write 4 offset value(s) to mc-07 now?" in question and "Operator anna" in question
            assert "recorded in the history store" in question
            assert control.values["G54.Z"] == VALUES["G54.Z"], "nothing is written before the second yes"
            await pilot.press("y")
            await settle(pilot)
            for path, change in CHANGES.items():
                assert control.values[path] == pytest.approx(VALUES[path] + change, abs=1e-9)
            line = app.state.send_line
            assert line == (
                "applied on mc-07 by anna: read back G54.Z -412.5530, G55.Z -412.4650, H5 -0.0210, H12 0.0055 mm"
            )
            assert ("send to machine", line) in notes(app)

    run(scenario())
    with open_store(tmp_path / "history.sqlite", machine="mc-07") as store:
        attempts = store.link_attempts()
    assert [(a.outcome, a.operator, a.machine) for a in attempts] == [("applied", "anna", "mc-07")]
    assert {c.register: c.outcome for c in attempts[0].components} == dict.fromkeys(MAP, "confirmed")


def test_refusals_in_one_line_and_nothing_written(tmp_path: Path, control: TestControl) -> None:
    async def scenario() -> None:
        app = make_app(tmp_path, control)
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            # a program starts between the diff and the write: the interlock refuses, in one line
            await pilot.press("w")
            await settle(pilot)
            await pilot.press("s")
            await pilot.pause()
            control.running = True
            await pilot.press("y")
            await settle(pilot)
            control.running = False
            assert app.state.send_line.startswith("refused on mc-07 by anna: ")
            assert "interlock" in app.state.send_line and "\n" not in app.state.send_line
            assert control.values == VALUES
            # the second question answered no: nothing written, nothing recorded
            await pilot.press("w")
            await settle(pilot)
            await pilot.press("s")
            await pilot.pause()
            await pilot.press("n")
            await settle(pilot)
            assert control.values == VALUES
            # another client edits an offset after the report was opened: the diff says so and only closes
            control.edit("H5", -0.011)
            await pilot.press("w")
            await settle(pilot)
            screen = app.screen
            assert isinstance(screen, SendScreen) and screen.why is not None
            assert screen.why.startswith("the table changed since the plan (H5)")
            assert not screen.query("#send-yes")
            await pilot.press("s")
            await pilot.pause()
            assert isinstance(app.screen, SendScreen), "s does nothing when the plan cannot be sent"
            await pilot.press("escape")
            await settle(pilot)

    run(scenario())
    assert control.values == {**VALUES, "H5": -0.011}
    with open_store(tmp_path / "history.sqlite", machine="mc-07") as store:
        assert [a.outcome for a in store.link_attempts()] == ["refused"]


def test_without_a_link_there_is_no_send(tmp_path: Path, control: TestControl) -> None:
    async def scenario() -> None:
        app = make_app(tmp_path, control, link=False)
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            assert not app.state.allows("send")
            await pilot.press("w")
            await settle(pilot)
            assert not isinstance(app.screen, SendScreen)

    run(scenario())


def test_link_and_current_together_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from setupfix.cli import main

    link = tmp_path / "link.toml"
    link.write_text('[link]\nprotocol = "opcua"\nendpoint = "opc.tcp://127.0.0.1:1"\n')
    argv = ["tui", str(SAMPLE / "report.csv"), "--model", str(SAMPLE / "model.toml"), "--link", str(link)]
    assert main([*argv, "--current", str(SAMPLE / "current.csv")]) == 1
    assert "--link and --current are two sources of the current offsets" in capsys.readouterr().err
