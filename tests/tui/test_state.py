"""The operator's session as plain data: its changes need no screen, and it loads no Textual."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tui.conftest import CYCLE_01, MODEL

from setupfix.optimize import OPTIMIZERS
from setupfix.tui.session import FolderWatch, open_report
from setupfix.tui.state import SORT_ORDER, Inputs, SessionState
from setupfix.usecases.correct import load_request


def test_the_session_and_its_state_load_no_textual() -> None:
    """The headless parts of the TUI import without Textual (the app is imported when asked for)."""
    code = (
        "import sys, setupfix.tui, setupfix.tui.session, setupfix.tui.state\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'textual'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_keys_change_the_state_round_their_choices() -> None:
    state = SessionState.start(Inputs(model=MODEL, optimizer="ga"))
    assert (state.model_path, state.optimizer, state.current()) == (MODEL, "ga", None)
    # nothing opened: no station to filter, no cycle to step to (the screen is left as it is)
    assert not state.next_station() and not state.step_part(1) and not state.jump_part("latest")
    seen: list[str] = []
    for _ in OPTIMIZERS:
        state.next_optimizer()
        seen.append(state.optimizer)
    assert sorted(seen) == sorted(OPTIMIZERS) and seen[-1] == "ga"
    state.optimizer = "not one"
    state.next_optimizer()
    assert state.optimizer == "exact"
    sorts: list[str | None] = []
    for _ in SORT_ORDER:
        state.next_sort()
        sorts.append(state.sort_key)
    assert sorts == [*SORT_ORDER[1:], None]
    state.sort_by("deviation")
    assert state.sort_key == "deviation"
    state.sort_by("deviation")  # the same header again: the model's order
    assert state.sort_key is None


def test_a_report_opened_then_one_that_failed() -> None:
    state = SessionState.start(Inputs(model=MODEL))
    state.problem = "opening …"
    state.report_opened(open_report(load_request(MODEL), CYCLE_01))
    c = state.current()
    assert c is not None and state.problem == "" and state.unit() == "mm" and state.feed_text() == ""
    assert state.next_station() and state.station == "P1"
    assert state.jump_part("latest") and state.part_index == 0  # one cycle: first and latest are the same
    state.open_failed("bad.csv:2: expected a number")
    assert state.current() is None and state.opened is None and state.problem == "✗ bad.csv:2: expected a number"


def test_the_series_comes_from_the_store_else_the_watched_folder_else_the_report_s(tmp_path: Path) -> None:
    state = SessionState.start(Inputs(model=MODEL))
    assert state.series_source() == ""
    state.report_path = CYCLE_01
    assert state.series_source() == str(CYCLE_01.parent)
    state.folder_watch = FolderWatch(tmp_path)
    assert state.series_source() == str(tmp_path)
    state.inputs = Inputs(model=MODEL, db="h.db")
    assert state.series_source() == "h.db"
