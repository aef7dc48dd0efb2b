"""Fixtures of the TUI tests: the app built from the same Inputs as the command line."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Coroutine
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from conftest import GUIDE_PINS

if TYPE_CHECKING:
    from textual.pilot import Pilot

    from setupfix.tui.app import SetupfixApp

MODEL = GUIDE_PINS / "model.toml"
CYCLE_01 = GUIDE_PINS / "cycle_01.csv"

#: ``make_app(report=…, **inputs)`` (the fixture below): a SetupfixApp with these Inputs.
MakeApp = Callable[..., "SetupfixApp"]


@pytest.fixture
def make_app(tmp_path: Path) -> MakeApp:
    """``make_app(report=…, **inputs)``: a SetupfixApp on the guide-pins model, exports into tmp_path."""
    from setupfix.tui.app import SetupfixApp
    from setupfix.tui.state import Inputs

    def make(report: Path | None = CYCLE_01, **kw: Any) -> SetupfixApp:
        kw.setdefault("model", MODEL)
        kw.setdefault("offsets", str(tmp_path / "offsets.csv"))
        kw.setdefault("trials", 1)
        return SetupfixApp(Inputs(report=report, **kw))

    return make


def run(coro: Coroutine[Any, Any, None]) -> None:
    """Run one Pilot scenario (no pytest-asyncio here: one event loop per test)."""
    asyncio.run(coro)


async def settle(pilot: Pilot[None]) -> None:
    """Wait until every worker has finished and its result reached the screen."""
    from textual.worker import WorkerFailed

    with contextlib.suppress(WorkerFailed):  # the app shows it; the tests look at what it shows
        await pilot.app.workers.wait_for_complete()
    await pilot.pause()
    await pilot.pause()
