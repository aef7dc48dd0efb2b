"""The operator's screen (issue 37 item 9): at 80×24 the dimensions that need the operator come first and fill
the room; the engineer's optimiser choice and comparison are hidden from the operator; the export keeps the
controller chosen and never overwrites a file without asking."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from textual.widgets import DataTable, Input, Select, TabbedContent
from tui.conftest import CYCLE_01, MODEL, MakeApp, run, settle

from setupfix.cli import main
from setupfix.tui.screens import ConfirmScreen, ExportScreen
from setupfix.tui.state import attention_order
from setupfix.views.correction import DimensionRow

if TYPE_CHECKING:
    from setupfix.tui.app import SetupfixApp


def _screen(app: SetupfixApp) -> list[str]:
    """The screen as the operator sees it, one string per terminal line."""
    return [strip.text for strip in app.screen._compositor.render_strips()]


def _names(table: DataTable[Any]) -> list[str]:
    return [str(table.get_row(k)[1]) for k in table.rows]


def _rank(flags: tuple[str, ...]) -> int:
    """0 out of tolerance (measured or predicted), 1 binding or in the guard band, 2 the rest."""
    if "out" in flags or "out_before" in flags:
        return 0
    return 1 if "binding" in flags or "guard" in flags else 2


FLAGS = st.lists(st.sampled_from(["out_before", "out", "guard", "binding", "given_up"]), unique=True, max_size=3)


@given(
    st.lists(
        st.tuples(FLAGS.map(tuple), st.floats(-0.2, 0.2, allow_nan=False)),
        max_size=12,
    )
)
def test_attention_order_is_out_then_binding_or_at_a_limit_then_the_least_margin(
    spec: list[tuple[tuple[str, ...], float]],
) -> None:
    rows = [
        DimensionRow(f"D{i}", f"D{i}", "P1", 0.0, -0.1, 0.1, 0.0, 0.0, margin, flags)
        for i, (flags, margin) in enumerate(spec)
    ]
    got = attention_order(rows)
    assert sorted(r.id for r in got) == sorted(r.id for r in rows)  # a permutation: nothing lost or doubled
    keys = [(_rank(r.flags_), r.margin_after) for r in got]
    assert keys == sorted(keys)
    for a, b in itertools.pairwise(got):  # ties keep the model's order
        if (_rank(a.flags_), a.margin_after) == (_rank(b.flags_), b.margin_after):
            assert int(a.id[1:]) < int(b.id[1:])


@pytest.mark.slow
@pytest.mark.parametrize("size", [(80, 24), (100, 26)])
def test_a_small_screen_shows_the_out_binding_and_least_margin_dimensions_first_and_more_rows(
    make_app: MakeApp, tmp_path: Path, size: tuple[int, int]
) -> None:
    """A variant of the guide-pins cycle with P4 D4 pushed out of tolerance (-0.1229 against ±0.100)."""
    report = tmp_path / "pushed.csv"
    text = CYCLE_01.read_text(encoding="utf-8")
    old = "P4 D4,30.0000,29.9171,-0.0829,"
    assert old in text
    report.write_text(text.replace(old, "P4 D4,30.0000,29.8771,-0.1229,"), encoding="utf-8")

    async def scenario() -> None:
        app = make_app(report=report)
        async with app.run_test(size=size) as pilot:
            await settle(pilot)
            expected = [r.name for r in sorted(_view_rows(app), key=lambda r: (_rank(r.flags_), r.margin_after))]
            names = _names(app.query_one("#dimensions", DataTable))
            assert names == expected
            rank = {r.name: _rank(r.flags_) for r in _view_rows(app)}
            assert names[0] == "P4 D4" and rank[names[1]] == 1  # out, then a binding one (not the model's order)
            assert names != [r.name for r in _view_rows(app)]
            lines = _screen(app)
            visible = [n for n in names if any(f" {n} " in line for line in lines)]
            assert visible == names[: len(visible)] and len(visible) >= 7  # 3 before (issue 37)
            assert any(" G54 " in line for line in lines)  # the recommendation still on the first screen

    run(scenario())


def _view_rows(app: SetupfixApp) -> list[DimensionRow]:
    from setupfix.views.correction import dimension_rows

    c = app.state.current()
    assert c is not None
    return dimension_rows(c)


@pytest.mark.slow
def test_the_optimiser_choice_and_the_comparison_are_the_engineer_s(make_app: MakeApp) -> None:
    async def scenario() -> None:
        app = make_app()
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot)
            tabs = app.query_one(TabbedContent)
            footer = "\n".join(_screen(app)[-2:])
            assert "Optim." not in footer and "Compare" not in footer and "Export" in footer
            assert "Compare" not in _screen(app)[0]  # the tab bar (no header below 30 lines? the first line)
            await pilot.press("p", "c", "2")
            await settle(pilot)
            assert app.optimizer == "exact" and app.comparison is None and tabs.active == "correct"
            # ctrl+e: the engineer's keys and tab appear and work
            await pilot.press("ctrl+e")
            await pilot.pause()
            assert "Optim." in "\n".join(_screen(app)[-2:])
            await pilot.press("p")
            await settle(pilot)
            assert app.optimizer == "cripso"
            await pilot.press("2")
            await pilot.pause()
            assert tabs.active == "compare"
            # and hidden again: the operator is taken off the compare tab
            await pilot.press("ctrl+e")
            await pilot.pause()
            assert tabs.active == "correct" and "Optim." not in "\n".join(_screen(app)[-2:])

    run(scenario())


@pytest.mark.slow  # imports the app (Textual): seconds on a loaded box
def test_the_engineer_flag_reaches_the_app_and_the_help_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from setupfix.tui.app import SetupfixApp
    from setupfix.tui.screens.help import HELP

    started = []
    monkeypatch.setattr(SetupfixApp, "run", lambda self: started.append(self.state.engineer))
    assert main(["tui", str(CYCLE_01), "--model", str(MODEL)]) == 0
    assert main(["tui", str(CYCLE_01), "--model", str(MODEL), "--engineer"]) == 0
    assert started == [False, True]
    engineer = HELP.split("# Engineer keys", 1)[1]
    assert "--engineer" in engineer and "ctrl+e" in engineer and "| `p` |" in engineer and "| `c` |" in engineer
    assert "| `p` |" not in HELP.split("# Engineer keys", 1)[0]


@pytest.mark.slow
def test_the_export_keeps_the_controller_and_asks_before_overwriting(make_app: MakeApp, tmp_path: Path) -> None:
    """Fanuc written, then e again: Fanuc and its file offered; an existing file (the program, or a foreign
    offsets.csv) is overwritten only on a yes."""
    foreign = tmp_path / "offsets.csv"
    foreign.write_text("someone else's file\n", encoding="utf-8")

    async def export_screen(pilot: Any) -> ExportScreen:
        await pilot.press("e")
        for _ in range(20):
            if isinstance(pilot.app.screen, ExportScreen):
                break
            await pilot.pause()
        assert isinstance(pilot.app.screen, ExportScreen)
        return pilot.app.screen

    async def confirm(pilot: Any) -> ConfirmScreen:
        await pilot.press("ctrl+s")
        await pilot.pause()
        assert isinstance(pilot.app.screen, ConfirmScreen), type(pilot.app.screen)
        return pilot.app.screen

    async def scenario() -> None:
        app = make_app()
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            # the first export, csv onto a file that exists: asked, "n" keeps it
            await export_screen(pilot)
            question = await confirm(pilot)
            assert str(foreign) in question.question
            await pilot.press("n")
            await pilot.pause()
            assert foreign.read_text(encoding="utf-8") == "someone else's file\n"
            assert isinstance(app.screen, ExportScreen)  # back on the export, nothing written
            # fanuc instead: a new file, written without a question
            app.screen.query_one("#export-controller", Select).value = "fanuc"
            await pilot.pause()
            program = tmp_path / "offsets.nc"
            assert app.screen.query_one("#export-path", Input).value == str(program)
            await pilot.press("ctrl+s")
            await settle(pilot)
            first = program.read_text(encoding="utf-8")
            assert first.startswith("%") or "G10" in first
            # the next export: fanuc and its file again, not csv
            screen = await export_screen(pilot)
            assert screen.query_one("#export-controller", Select).value == "fanuc"
            assert screen.query_one("#export-path", Input).value == str(program)
            assert screen.text == first
            program.write_text("edited at the control\n", encoding="utf-8")
            await confirm(pilot)
            await pilot.press("escape")  # escape is a no
            await pilot.pause()
            assert program.read_text(encoding="utf-8") == "edited at the control\n"
            await confirm(pilot)
            await pilot.press("y")
            await settle(pilot)
            assert program.read_text(encoding="utf-8") == first
            assert foreign.read_text(encoding="utf-8") == "someone else's file\n"

    run(scenario())
