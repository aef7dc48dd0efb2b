"""The ``model map`` screen: mark questions, give WKS and tool, answer; the same use case as the CLI."""

from __future__ import annotations

import tomllib
from pathlib import Path

from conftest import SAMPLES
from tui.conftest import run

from setupfix.usecases.model_init import scaffold_model
from setupfix.usecases.model_map import map_listing

PLATE = SAMPLES / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF"


def test_marked_rows_are_answered_together_and_a_refusal_is_shown(tmp_path: Path) -> None:
    from textual.widgets import DataTable, Input, Label

    from setupfix.tui.screens.model_map import ModelMapApp

    model = tmp_path / "plate.toml"
    model.write_text(scaffold_model([PLATE]).text, encoding="utf-8")
    out = tmp_path / "answered.toml"
    app = ModelMapApp(model, out=out)

    async def scenario() -> None:
        async with app.run_test(size=(150, 40)) as pilot:
            await pilot.pause()
            screen = app.map_screen
            table = screen.query_one("#map-table", DataTable)
            assert table.row_count == 21  # DS002, DS003: distances, not asked
            await pilot.press("space")  # Q1
            await pilot.press("down", "space")  # Q2
            screen.query_one("#map-wks", Input).value = "G54"
            tool = screen.query_one("#map-tool", Input)
            tool.value = "drill"
            tool.focus()
            await pilot.press("enter")
            await pilot.pause()
            assert "refused" in str(screen.query_one("#map-status", Label).render())
            assert not out.exists()
            tool.value = "T4"
            tool.focus()
            await pilot.press("enter")
            await pilot.pause()
            assert table.row_count == 19  # the two answered leave the list
            assert "2 question(s) answered" in str(screen.query_one("#map-status", Label).render())
            table.focus()
            await pilot.press("a")  # every row left
            tool.value = "T5"
            tool.focus()
            await pilot.press("enter")
            await pilot.pause()
            assert table.row_count == 0

    run(scenario())
    assert map_listing(out).questions == () and map_listing(model).questions  # the model itself is untouched
    raw = tomllib.loads(out.read_text(encoding="utf-8"))
    assert "draft" not in raw["process"] and set(raw["tools"]) == {"T4", "T5"}
