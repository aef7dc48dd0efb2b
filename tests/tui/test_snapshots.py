"""Snapshots of the main screens at 80×24 and 160×48 (pytest-textual-snapshot).

Update after a deliberate change with ``python -m pytest tests/tui/test_snapshots.py --snapshot-update``
and look at the SVGs before committing them.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT
from textual.pilot import Pilot

from setupfix.tui.app import SetupfixApp
from setupfix.tui.state import Inputs

MODEL = Path("sample_reports/guide_pins/model.toml")
CYCLE_01 = Path("sample_reports/guide_pins/cycle_01.csv")

#: The ``snap_compare`` fixture: ``(app, *, run_before=…, terminal_size=…) -> bool`` (the plugin is untyped).
SnapCompare = Callable[..., bool]


@pytest.fixture(autouse=True)
def _in_the_repository(monkeypatch: pytest.MonkeyPatch) -> None:
    # relative paths: the screens show file names as the operator typed them
    monkeypatch.chdir(ROOT)


async def _settled(pilot: Pilot[Any]) -> None:
    # workers done, their results laid out, breakpoint classes applied (a loaded machine needs the extra turns)
    await pilot.app.workers.wait_for_complete()
    for _ in range(3):
        await pilot.pause()


def _app(report: Path = CYCLE_01) -> SetupfixApp:
    return SetupfixApp(Inputs(model=MODEL, report=report))


@pytest.mark.parametrize("size", [(80, 24), (160, 48)], ids=["80x24", "160x48"])
def test_correction_screen(snap_compare: SnapCompare, size: tuple[int, int]) -> None:
    assert snap_compare(_app(), run_before=_settled, terminal_size=size)


def test_export_confirmation(snap_compare: SnapCompare) -> None:
    async def run_before(pilot: Pilot[Any]) -> None:
        await _settled(pilot)
        await pilot.press("e")
        while type(pilot.app.screen).__name__ != "ExportScreen":
            await pilot.pause()
        await pilot.pause()

    assert snap_compare(_app(), run_before=run_before, terminal_size=(80, 24))
