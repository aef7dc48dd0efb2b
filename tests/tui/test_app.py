"""The operator's screen driven by Pilot: open, optimise, compare, export, bad files, folders.

Few apps, several steps each: starting an app costs about a second on the shared
2-core machine, so one scenario per app keeps the suite short.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from conftest import GUIDE_PINS, SAMPLES, SHARED
from textual.widgets import DataTable, Input, Sparkline, TabbedContent
from tui.conftest import CYCLE_01, MODEL, MakeApp, run, settle

from setupfix.cli import main
from setupfix.model import load_model
from setupfix.tui.screens import ExportScreen
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, SolveOptions

if TYPE_CHECKING:
    from setupfix.tui.app import SetupfixApp
    from setupfix.usecases.requests import CycleCorrection

CONTROLLERS = SAMPLES / "controllers"
#: The NIST plate, its model and its process log (the log lives in the shared folder).
PLATE = SAMPLES / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif"
PLATE_MODEL = Path(__file__).parents[1] / "data" / "nist_plate.toml"
PLATE_LOG = SHARED / "real-series" / "nist-mtc" / "plate_process.csv"


def _notes(app: SetupfixApp) -> list[str]:
    return [n.message for n in app._notifications]


def _on_screen(app: SetupfixApp) -> CycleCorrection:
    """The correction of the cycle on screen (there is one)."""
    c = app.state.current()
    assert c is not None
    return c


def _rows(table: DataTable[Any]) -> list[list[str]]:
    """Every row's cells as the operator reads them (cells are literal Text, never markup)."""
    return [[str(c) for c in table.get_row(k)] for k in table.rows]


@pytest.mark.slow
def test_open_sort_filter_export_then_a_bad_report(make_app: MakeApp, tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(
        "characteristic,nominal,actual,deviation,lower,upper,unit,part\nP1 D1,25,abc,x,-0.1,0.1,mm,c1\n",
        encoding="utf-8",
    )

    async def scenario() -> None:
        app = make_app()
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            # the sample: every dimension and register, README's δ and bonus, binding marked ●
            c = app.state.current()
            assert c is not None and c.result.optimizer == "exact"
            dims = app.query_one("#dimensions", DataTable)
            assert dims.row_count == 28 and app.query_one("#registers", DataTable).row_count == 10
            text = str(app.query_one("#summary").render())
            assert "+0.0171" in text and "+0.0822" in text and "+0.0651" in text
            assert {r[1] for r in _rows(dims) if "●" in str(r[0])} == {"P1 D6", "P1 D7"}
            # the mouse: a click on a column header sorts by it
            await pilot.click("#dimensions", offset=(20, 1))
            assert app.sort_key == "deviation"
            assert next(str(r[3]) for r in _rows(dims)) == "-0.0829"
            app.sort_key = None
            # a resize to a wide terminal adds the margins; back to 80 columns removes them
            await pilot.resize_terminal(160, 48)
            await pilot.pause()
            assert len(dims.columns) == 10
            await pilot.resize_terminal(80, 24)
            await pilot.pause()
            assert len(dims.columns) == 8
            # station filter and sort
            await pilot.press("f", "s")
            names = [r[1] for r in _rows(dims)]
            assert len(names) == 7 and all(n.startswith("P1") for n in names)
            assert names[:2] == ["P1 D6", "P1 D7"] or set(names[:2]) == {"P1 D6", "P1 D7"}  # least margin first
            # export: the confirmation shows the text; ctrl+s writes exactly it
            await pilot.press("e")
            await pilot.pause()
            screen = app.screen
            assert isinstance(screen, ExportScreen)
            shown = screen.text
            assert str(app.screen.query_one("#export-text").render()) == shown
            await pilot.press("ctrl+s")
            await pilot.pause()
            written = (tmp_path / "offsets.csv").read_text(encoding="utf-8")
            assert written == shown
            assert main(["correct", "--model", str(MODEL), str(CYCLE_01), "--offsets", str(tmp_path / "cli.csv")]) == 0
            assert written == (tmp_path / "cli.csv").read_text(encoding="utf-8")  # as `correct --offsets`
            assert any("wrote csv offsets" in n for n in _notes(app))
            # a folder as target: refused, named, nothing written
            await pilot.press("e")
            await pilot.pause()
            app.screen.query_one("#export-path", Input).value = str(tmp_path)
            await pilot.press("ctrl+s")
            await pilot.pause()
            assert any(n.title == "export failed" and str(tmp_path) in n.message for n in app._notifications)
            # a bad report: a notification naming file and line, the stale correction gone
            app.controller.report_picked(bad)
            await settle(pilot)
            assert any(f"{bad}:2:" in n for n in _notes(app))
            assert app.state.current() is None and app.is_running
            assert f"{bad}:2:" in str(app.query_one("#summary").render())
            await pilot.press("e")
            assert any("nothing to export" in n for n in _notes(app))
            # help
            await pilot.press("question_mark")
            await pilot.pause()
            assert type(app.screen).__name__ == "HelpScreen"
            await pilot.press("escape")

    run(scenario())


@pytest.mark.slow
def test_optimiser_choice_and_compare_with_cancel(make_app: MakeApp) -> None:
    async def scenario() -> None:
        app = make_app(engineer=True)  # the optimiser choice and the comparison are the engineer's
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot)
            await pilot.press("p")
            await settle(pilot)
            c = _on_screen(app)
            assert app.optimizer == "cripso" and c.result.optimizer == "cripso"
            expected = correct_report(
                CorrectRequest(load_model(MODEL), solve=SolveOptions("cripso", 0)), CYCLE_01
            ).cycles[0]
            assert c.result.margin_after == expected.result.margin_after
            assert "cripso" in str(app.query_one("#summary").render())
            await pilot.press("c")
            await settle(pilot)
            comp = app.comparison
            assert comp is not None
            assert [m.optimizer for m in comp.methods] == ["cripso", "pso", "ga", "coa", "cs"]
            assert app.query_one("#compare-table", DataTable).row_count == 6
            assert all(m.f1.max() <= comp.exact.margin_after + 1e-9 for m in comp.methods)
            assert len(app.query("Sparkline.curve")) == 5
            app.comparison = None
            app.inputs = dataclasses.replace(app.inputs, trials=12)  # long enough to cancel
            await pilot.press("c", "x")
            await settle(pilot)
            assert app.comparison is None
            assert "cancelled" in str(app.query_one("#compare-status").render())

    run(scenario())


@pytest.mark.slow
def test_reports_that_do_not_match_show_the_match_table(make_app: MakeApp, tmp_path: Path) -> None:
    none = tmp_path / "none.csv"
    none.write_text(
        CYCLE_01.read_text(encoding="utf-8")
        .replace("P1 D", "Pin1 D")
        .replace("P2 D", "Pin2 D")
        .replace("P3 D", "Pin3 D")
        .replace("P4 D", "Pin4 D"),
        encoding="utf-8",
    )
    some = tmp_path / "some.csv"
    some.write_text(CYCLE_01.read_text(encoding="utf-8").replace("P1 D", "Pin1 D"), encoding="utf-8")

    async def scenario() -> None:
        app = make_app(report=none)
        async with app.run_test() as pilot:
            await settle(pilot)
            assert app.query_one(TabbedContent).active == "match"
            assert app.state.current() is None
            rows = _rows(app.query_one("#match-table", DataTable))
            assert len(rows) == 28 and all(str(r[0]) == "✗" for r in rows)
            assert "P1 D1" in next(r for r in rows if r[1] == "Pin1 D1")[5]
            app.controller.report_picked(some)
            await settle(pilot)
            assert app.state.current() is not None  # corrected without P1; the table says which are left out
            rows = _rows(app.query_one("#match-table", DataTable))
            assert sum(str(r[0]) == "✗" for r in rows) == 7
            assert "7 characteristic(s)" in str(app.query_one("#match-status").render())

    run(scenario())


@pytest.mark.slow
def test_a_folder_is_watched_and_the_newest_finished_report_opened(make_app: MakeApp, tmp_path: Path) -> None:
    shutil.copy(GUIDE_PINS / "cycle_01.csv", tmp_path / "a.csv")

    async def scenario() -> None:
        app = make_app(report=tmp_path, poll_seconds=0.05)
        async with app.run_test() as pilot:
            for _ in range(40):
                await pilot.pause(0.05)
                await settle(pilot)
                if app.state.current() is not None:
                    break
            assert _on_screen(app).part.report.endswith("a.csv")
            shutil.copy(GUIDE_PINS / "cycle_02.csv", tmp_path / "b.csv")
            for _ in range(40):
                await pilot.pause(0.05)
                await settle(pilot)
                if app.state.current() is not None and _on_screen(app).part.report.endswith("b.csv"):
                    break
            assert _on_screen(app).part.report.endswith("b.csv")

    run(scenario())


@pytest.mark.slow
def test_history_from_the_store_one_key_diagnose_and_the_export_recorded(make_app: MakeApp, tmp_path: Path) -> None:
    from setupfix.store import open_store
    from setupfix.usecases.history import ImportRequest, import_history

    db = tmp_path / "h.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(tuple(sorted(GUIDE_PINS.glob("cycle_0*.csv")))))

    async def scenario() -> None:
        app = make_app(db=db)
        async with app.run_test(size=(100, 40)) as pilot:
            await settle(pilot)
            cycles = _rows(app.query_one("#history-cycles", DataTable))
            assert [str(r[3]) for r in cycles] == ["+0.0171", "+0.0484", "+0.0681", "+0.0296", "+0.0489"]
            await pilot.press("d")
            await settle(pilot)
            assert app.query_one(TabbedContent).active == "history"
            text = str(app.query_one("#history-diagnosis").render())
            assert "diagnosis of" in text and "residual RMS" in text
            await pilot.press("1", "e")
            await pilot.pause()
            await pilot.press("ctrl+s")
            await settle(pilot)
            with open_store(db) as store:
                log = store.corrections()
            x = _on_screen(app).result.x
            assert app.opened is not None
            moved = {reg.register: v for reg, v in zip(app.opened.model.registers, x, strict=True) if v}
            logged = dict(zip(log["register"], log["delta"].round(6), strict=True))
            assert logged == {k: round(v, 6) for k, v in moved.items()}
            assert any("recorded" in n for n in _notes(app))

    run(scenario())


@pytest.mark.slow
def test_thermal_panel_shows_the_drift_and_the_feed_forward(make_app: MakeApp, tmp_path: Path) -> None:
    from conftest import SAMPLES

    from setupfix.inputs.thermal_files import predict_drift
    from setupfix.usecases.thermal_feedforward import thermal_feed_forward
    from setupfix.usecases.thermal_fit import fit_file

    saved = tmp_path / "grey.json"
    fit_file(SAMPLES / "thermal" / "train_variable.csv", "grey-ls", target="error_z", unit="mm", out=saved)
    # the simulated test log, moved to the day of cycle 01 (parts cut 2026-11-02T08:00)
    log = tmp_path / "temps.csv"
    log.write_text(
        (SAMPLES / "thermal" / "test_variable.csv").read_text(encoding="utf-8").replace("2026-01-05T", "2026-11-02T"),
        encoding="utf-8",
    )
    expected = predict_drift(saved, log)
    feed = thermal_feed_forward(load_model(MODEL), saved, log, measured_at="2026-11-02T08:00:00")

    async def scenario() -> None:
        app = make_app(thermal=saved, temperatures=log)
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot)
            await settle(pilot)
            await pilot.press("3")
            text = str(app.query_one("#thermal-status").render())
            assert f"{expected.latest:+.4f} mm" in text and "grey" in text
            curve = app.query_one("#thermal-curve", Sparkline)
            assert (
                curve.display
                and curve.data is not None
                and list(curve.data) == [float(v) for v in expected.drift[-120:]]
            )
            assert feed.line() in str(app.query_one("#thermal-feed").render())
            assert feed.line() in str(app.query_one("#summary").render())
            # the export holds the feed-forward, exactly as `correct --offsets --thermal` writes it
            await pilot.press("1", "e")
            await pilot.pause()
            await pilot.press("ctrl+s")
            await settle(pilot)
            assert (
                main(
                    [
                        "correct",
                        "--model",
                        str(MODEL),
                        str(CYCLE_01),
                        "--offsets",
                        str(tmp_path / "cli.csv"),
                        "--thermal",
                        str(saved),
                        "--temperatures",
                        str(log),
                    ]
                )
                == 0
            )
            written = (tmp_path / "offsets.csv").read_text(encoding="utf-8")
            assert written == (tmp_path / "cli.csv").read_text(encoding="utf-8")
            assert feed.applied and _on_screen(app).corrections["T5"] == _on_screen(app).x[8] + feed.shift

    run(scenario())


def test_the_command_line_gives_the_app_correct_s_reader_cycle_and_thermal_options(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """``setupfix tui`` takes the options of ``correct`` (same adders) and hands them to the app unchanged."""
    from setupfix.tui.app import SetupfixApp
    from setupfix.usecases.requests import CycleOptions, ReadOptions

    started = []
    monkeypatch.setattr(SetupfixApp, "run", lambda self: started.append(self.inputs))
    assert (
        main(
            [
                "tui",
                str(CYCLE_01),
                "--model",
                str(MODEL),
                "--columns",
                "actual=Meas",
                "--unit",
                "inch",
                "--lenient",
                "--stations",
                "P1,P2,P3,P4",
                "--strict",
                "--thermal",
                "t.json",
                "--temperatures",
                "log.csv",
                "--at",
                "2026-11-02T09:00:00",
                "--thermal-dead-band",
                "0.002",
            ]
        )
        == 0
    )
    inputs = started[0]
    assert inputs.read == ReadOptions(unit="inch", columns="actual=Meas", lenient=True)
    assert inputs.cycles == CycleOptions(("P1", "P2", "P3", "P4"), strict=True)
    assert (str(inputs.thermal), str(inputs.temperatures), inputs.at, inputs.thermal_dead_band) == (
        "t.json",
        "log.csv",
        "2026-11-02T09:00:00",
        0.002,
    )


@pytest.mark.slow
def test_compare_solves_the_problem_correct_solves(make_app: MakeApp, tmp_path: Path) -> None:
    """The compare tab's exact result is the correction shown: the guarded problem with the register costs
    (controllers sample: T12 costs 3), not the problem on the real limits."""
    import numpy as np

    from setupfix.optimize import get_optimizer

    model = tmp_path / "m.toml"
    model.write_text(
        (CONTROLLERS / "model.toml").read_text(encoding="utf-8") + "\n[safety]\nuncertainty = 0.004\n", encoding="utf-8"
    )

    async def scenario() -> None:
        # compare measures against the paper's objective (issue 22): the correction shown is that one when asked
        app = make_app(report=CONTROLLERS / "report.csv", model=model, objective="paper", engineer=True)
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot)
            c = _on_screen(app)
            await pilot.press("c")
            await settle(pilot)
            comp = app.comparison
            assert comp is not None and comp.problem is c.posed.guarded
            raw = c.recommendation.result
            assert c.verdict == "apply" and np.array_equal(c.x, raw.x)  # the correction shown is the optimum
            assert np.array_equal(comp.exact.x, raw.x) and comp.exact.margin_after == raw.margin_after
            assert np.any(c.posed.guarded.cost != 1.0)
            # the real-limit problem is another one: its exact optimum is not what correct shows
            other = get_optimizer("exact", objective="paper").solve(c.problem)
            assert not np.array_equal(other.x, raw.x) or other.margin_after != raw.margin_after

    run(scenario())


@pytest.mark.slow
def test_names_that_look_like_markup_are_shown_as_written(make_app: MakeApp, tmp_path: Path) -> None:
    """A dimension named ``D1 [/b] [red`` and a report ``cycle[1] [red.csv``: a DataTable reads a plain
    string as markup (the closing tag raised a MarkupError and the screen died); every name is literal."""
    model = tmp_path / "model.toml"
    model.write_text(
        MODEL.read_text(encoding="utf-8").replace('name = "D1"', 'name = "D1 [/b] [red"'), encoding="utf-8"
    )
    report = tmp_path / "cycle[1] [red.csv"
    report.write_text(CYCLE_01.read_text(encoding="utf-8").replace(" D1,", " D1 [/b] [red,"), encoding="utf-8")

    async def scenario() -> None:
        app = make_app(report=report, model=model)
        async with app.run_test(size=(100, 30)) as pilot:
            await settle(pilot)
            assert app.state.current() is not None, _notes(app)
            names = [r[1] for r in _rows(app.query_one("#dimensions", DataTable))]
            assert "P1 D1 [/b] [red" in names and "P4 D1 [/b] [red" in names
            assert "cycle[1] [red.csv" in app.sub_title.replace("\\[", "[")
            app.notify("[/b] a name from a report")  # toasts are literal too
            await pilot.pause()
            await pilot.press("e")
            await pilot.pause()
            await pilot.press("ctrl+s")
            await settle(pilot)
            assert "cycle[1] [red.csv" in (tmp_path / "offsets.csv").read_text(encoding="utf-8")

    run(scenario())


@pytest.mark.slow
def test_diagnose_key_tests_the_declared_factors_and_a_bad_one_is_a_notice(make_app: MakeApp, tmp_path: Path) -> None:
    """``tui --process LOG --factors …``: key d runs the same diagnosis as ``diagnose --factors`` (the effects
    it declares marked so); an unknown factor is a notice naming it, and the app stays up."""
    if not PLATE_LOG.is_file():
        pytest.skip("the NIST process log lives in the shared folder")
    folder = tmp_path / "plate"
    folder.mkdir()
    shutil.copy(PLATE, folder / PLATE.name)
    design = ("doe_tool_length", "doe_speed", "doe_tool_length*doe_speed")

    async def scenario(factors: tuple[str, ...]) -> tuple[list[list[str]], list[str]]:
        app = make_app(report=folder / PLATE.name, model=PLATE_MODEL, process=PLATE_LOG, factors=factors)
        async with app.run_test(size=(120, 40)) as pilot:
            await settle(pilot)
            await pilot.press("d")
            await settle(pilot)
            rows = _rows(app.query_one("#history-effects", DataTable))
            notes = [str(n.message) for n in app._notifications]
            assert app.is_running
        return rows, notes

    async def both() -> None:
        rows, _ = await scenario((",".join(design),))
        declared = [r for r in rows if str(r[0]).endswith("(declared)")]
        assert any("T5A" in str(r[1]) and "doe_speed" in str(r[1]) for r in declared), rows
        _, notes = await scenario(("doe_tool_length,spindle_sped",))
        assert any("'spindle_sped'" in n for n in notes), notes

    run(both())


@pytest.mark.slow
def test_the_file_picker_opens_at_the_nearest_folder_that_exists(tmp_path: Path) -> None:
    """After a report that could not be read (``/gone/bad.csv``), o opens the picker where that report would be,
    or above: a tree of a missing folder selected itself as a file and closed the picker twice (the app died)."""
    from textual.app import App

    from setupfix.tui.screens import OpenFileScreen

    picked: list[Path | None] = []

    class Host(App[None]):
        def on_mount(self) -> None:
            self.push_screen(OpenFileScreen("pick", tmp_path / "gone" / "deeper" / "bad.csv"), picked.append)

    async def scenario() -> None:
        app = Host()
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause()
            await pilot.pause()
            screen = app.screen
            assert isinstance(screen, OpenFileScreen) and screen.start == tmp_path and picked == []
            await pilot.press(*str(tmp_path / "b.csv"), "enter")
            await pilot.pause()
            assert picked == [tmp_path / "b.csv"] and app.is_running

    run(scenario())
