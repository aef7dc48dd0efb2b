"""The capability screen over a small host app: one row per stored characteristic, sparkline, rule flags."""

from __future__ import annotations

from pathlib import Path

import pytest
from spc_examples import closed_loop_store
from tui.conftest import MakeApp, run, settle

from setupfix.store import open_store
from setupfix.usecases.spc_report import SPARK, SpcRequest, capability_rows, sparkline, spc_report


def test_sparkline_maps_lowest_to_highest() -> None:
    assert sparkline([0.0, 1.0, 0.5, 0.25]) == "▁█▅▃"
    assert sparkline([2.0, 2.0]) == SPARK[3] * 2
    assert sparkline(list(range(100)), width=5) == "▁▃▅▇█"  # eight equal bins of the last five: 95 … 99
    assert sparkline([]) == ""


def test_capability_screen_shows_every_characteristic(tmp_path: Path) -> None:
    from textual.app import App
    from textual.widgets import DataTable

    from setupfix.tui.screens.capability import COLUMNS, CapabilityScreen

    with open_store(closed_loop_store(tmp_path)) as store:
        outcome = spc_report(store, SpcRequest())
    rows = capability_rows(outcome)
    assert len(rows) == 28 and rows[0].name == "P1 D1"
    assert rows[0].rules == "R1 R2 R3" and len(rows[0].spark) == 30
    assert rows[0].last_split.count("→") == 1

    class Host(App[None]):
        def on_mount(self) -> None:
            self.push_screen(CapabilityScreen(outcome))

    async def scenario() -> None:
        app = Host()
        async with app.run_test(size=(160, 40)) as pilot:
            await settle(pilot)
            screen = app.screen
            assert isinstance(screen, CapabilityScreen)
            table = screen.query_one("#capability", DataTable)
            assert table.row_count == 28 and len(table.columns) == len(COLUMNS)
            first = [str(c) for c in table.get_row_at(0)]
            assert first[0] == "P1 D1" and first[2] == rows[0].cpk and first[7] == "R1 R2 R3"
            assert set(first[6]) <= set(SPARK)
            await pilot.press("escape")
            await pilot.pause()
            assert not isinstance(app.screen, CapabilityScreen)

    run(scenario())


@pytest.mark.slow
def test_k_opens_the_capability_of_the_history_store_and_says_when_there_is_none(
    make_app: MakeApp, tmp_path: Path
) -> None:
    from textual.widgets import DataTable

    from setupfix.tui.screens.capability import CapabilityScreen
    from setupfix.tui.screens.help import HELP

    db = closed_loop_store(tmp_path)
    with open_store(db) as store:
        expected = capability_rows(spc_report(store, SpcRequest()))
    assert "| `k` |" in HELP and "| `Home` `End` |" in HELP

    async def scenario() -> None:
        app = make_app(db=db)
        async with app.run_test(size=(120, 40)) as pilot:
            await settle(pilot)
            await pilot.press("k")
            await settle(pilot)
            screen = app.screen
            assert isinstance(screen, CapabilityScreen), [n.message for n in app._notifications]
            table = screen.query_one("#capability", DataTable)
            shown = [[str(c) for c in table.get_row_at(i)] for i in range(table.row_count)]
            assert [(r[0], r[2], r[7]) for r in shown] == [(r.name, r.cpk, r.rules) for r in expected]
            await pilot.press("escape")
            await pilot.pause()
            assert not isinstance(app.screen, CapabilityScreen)
        # no store given: a message, no screen; a store that is not there: named, and not created
        for kwargs in ({}, {"db": tmp_path / "missing.db"}):
            app = make_app(**kwargs)
            async with app.run_test(size=(80, 24)) as pilot:
                await settle(pilot)
                await pilot.press("k")
                await settle(pilot)
                assert not isinstance(app.screen, CapabilityScreen) and app.is_running
                notes = [(n.title, n.message) for n in app._notifications]
                if kwargs:
                    assert any(t == "capability failed" and str(kwargs["db"]) in m for t, m in notes), notes
                    assert not kwargs["db"].exists()
                else:
                    assert any(t == "capability" and "--db STORE" in m for t, m in notes), notes

    run(scenario())
