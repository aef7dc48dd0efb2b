"""The operator's screen on a multi-axis model (issue 23): register components, 80×24 layout, Home/End,
the export's file name per controller, and a ``--current`` file re-read when the model is switched."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from conftest import SAMPLES
from textual.widgets import DataTable, Input, Select
from tui.conftest import MakeApp, run, settle

from setupfix.outputs.controllers import PROGRAM_SUFFIX, derived_program_number
from setupfix.tui.screens import ExportScreen
from setupfix.tui.widgets.summary import VERDICT_STYLE
from setupfix.usecases.export import offsets_text

if TYPE_CHECKING:
    from setupfix.tui.app import SetupfixApp
    from setupfix.tui.session import OpenedReport
    from setupfix.usecases.requests import CycleCorrection

XYZ = SAMPLES / "two_station_xyz"
MODEL = XYZ / "model.toml"


def _screen(app: SetupfixApp) -> list[str]:
    """The screen as the operator sees it, one string per terminal line."""
    return [strip.text for strip in app.screen._compositor.render_strips()]


def _on_screen(app: SetupfixApp) -> CycleCorrection:
    """The correction of the cycle on screen (there is one)."""
    c = app.state.current()
    assert c is not None
    return c


def _opened(app: SetupfixApp) -> OpenedReport:
    """The report opened (there is one)."""
    assert app.opened is not None
    return app.opened


def _export(app: SetupfixApp) -> ExportScreen:
    """The export confirmation on screen."""
    assert isinstance(app.screen, ExportScreen)
    return app.screen


def _rows(table: DataTable[Any]) -> list[list[str]]:
    return [[str(c) for c in table.get_row(k)] for k in table.rows]


def _three_cycles(folder: Path) -> Path:
    """cycle_01 … cycle_03 of the sample in one report: three parts, in that order."""
    lines = (XYZ / "cycle_01.csv").read_text(encoding="utf-8").splitlines()
    for n in (2, 3):
        lines += (XYZ / f"cycle_0{n}.csv").read_text(encoding="utf-8").splitlines()[1:]
    report = folder / "three.csv"
    report.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return report


@pytest.fixture
def two_models(tmp_path: Path) -> tuple[Path, Path, Path]:
    """The sample's model with the controller numbers a Siemens program needs (frames 1, 2; T1 D1, T2 D1),
    the same without the rotation, and a --current file for the first."""
    text = MODEL.read_text(encoding="utf-8")
    for old, new in (
        ('"G54"  # station P1', '"G54"  # station P1\nnumber = 1'),
        ('"G55"  # station P2', '"G55"  # station P2\nnumber = 2'),
        ('register = "H1"\n', 'register = "H1"\nnumber = 1\nedge = 1\n'),
        ('register = "H2"\n', 'register = "H2"\nnumber = 2\nedge = 1\n'),
    ):
        assert old in text
        text = text.replace(old, new)
    numbered = tmp_path / "numbered.toml"
    numbered.write_text(text, encoding="utf-8")
    without = tmp_path / "no_rotation.toml"
    without.write_text(text.replace("rotation = true", "rotation = false"), encoding="utf-8")
    current = tmp_path / "current.csv"
    rows = ["register,axis,value"]
    for reg, base in (("G54", -400.0), ("G55", -200.0)):
        rows += [f"{reg},X,{base:.3f}", f"{reg},Y,{base / 2:.3f}", f"{reg},Z,{base / 4:.3f}", f"{reg},C,0.0000"]
    rows += ["H1,,120.000", "D1,,5.000", "H2,,95.000"]
    current.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return numbered, without, current


@pytest.mark.slow
def test_multi_axis_at_80x24_home_end_and_the_export_name_per_controller(
    make_app: MakeApp, tmp_path: Path, two_models: tuple[Path, Path, Path]
) -> None:
    report = _three_cycles(tmp_path)
    model, _, current = two_models

    async def scenario() -> None:
        app = make_app(report=report, model=model, current=current)
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            c = app.state.current()
            assert c is not None and c.part.part == "cycle 01" and len(_opened(app).corrections) == 3
            # registers: every component with its controller register; the rotation in degrees, on its own grid
            regs = {r[1]: r for r in _rows(app.query_one("#registers", DataTable))}
            assert list(regs) == ["W1.X", "W1.Y", "W1.Z", "W1.C", "W2.X", "W2.Y", "W2.Z", "W2.C", "T1", "T1.R", "T2"]
            assert [regs[k][0] for k in ("W1.X", "W1.C", "W2.Z", "T1", "T1.R", "T2")] == [
                "G54",
                "G54",
                "G55",
                "H1",
                "D1",
                "H2",
            ]
            assert regs["W1.C"][6] == "°" and regs["W1.X"][6] == "mm" and regs["T1.R"][6] == "mm"
            assert regs["W1.C"][3] == f"{c.corrections['W1.C']:+.4f}"  # rotation_resolution 0.0001°
            assert regs["W1.X"][3] == f"{c.corrections['W1.X']:+.3f}"  # resolution 0.001 mm
            # the first screen: the verdict, the dimensions out of tolerance (measured or predicted) first and most
            # of the room for the dimensions (issue 37); the registers beneath, scrolled
            out = [
                d.name
                for d, dev in zip(c.model.dimensions, c.part.deviation, strict=True)
                if dev < d.lower or dev > d.upper
            ]
            assert out == ["P1 Face"]  # the sample's cycle 01: the face, 0.0509 against ±0.040
            lines = _screen(app)
            text = "\n".join(lines)
            assert lines[2].lstrip().startswith(VERDICT_STYLE[c.verdict][0]) and "δ before" in lines[3]
            dims = [r[1] for r in _rows(app.query_one("#dimensions", DataTable))]
            assert dims[0] == "P1 Face" and len(dims) == 16
            assert any(line.lstrip().startswith("✗✓    P1 Face") for line in lines)
            assert sum(any(f" {d} " in line for d in dims) for line in lines) >= 7
            shown = [rid for rid, row in regs.items() if any(f" {row[0]} " in ln and f" {rid} " in ln for ln in lines)]
            assert len(shown) >= 4 and shown == list(regs)[: len(shown)]
            assert "sort out, binding, margin" in text
            # Home/End: the latest and the first cycle ([ ] step one)
            await pilot.press("end")
            assert _on_screen(app).part.part == "cycle 03"
            await pilot.press("home")
            assert _on_screen(app).part.part == "cycle 01"
            await pilot.press("right_square_bracket")
            assert _on_screen(app).part.part == "cycle 02"
            await pilot.press("end")
            await pilot.pause()
            assert "cycle 03 (3/3" in str(app.query_one("#summary").render())
            # a resize to a large terminal: model order, the margins, the recommendation beside the dimensions
            await pilot.resize_terminal(160, 48)
            await pilot.pause()
            assert [r[1] for r in _rows(app.query_one("#dimensions", DataTable))][:3] == [
                "P1 Height",
                "P1 Hole 1 depth",
                "P1 Wall X",
            ]
            await pilot.resize_terminal(80, 24)
            await pilot.pause()
            # export: the file name follows the controller; the program is the one the use case writes
            await pilot.press("e")
            await pilot.pause()
            screen = _export(app)
            field, select = screen.query_one("#export-path", Input), screen.query_one("#export-controller", Select)
            assert field.value == str(tmp_path / "offsets.csv")
            for controller, suffix in [*PROGRAM_SUFFIX.items(), ("csv", ".csv")]:
                select.value = controller
                await pilot.pause()
                assert field.value == str(tmp_path / f"offsets{suffix}"), controller
            # Home/End in the dialog's field are the field's, not the cycle's
            field.focus()
            await pilot.press("home")
            assert _on_screen(app).part.part == "cycle 03" and field.cursor_position == 0
            select.value = "siemens"  # frame rotation RT; absolute (the current offsets); the cycle on screen
            await pilot.pause()
            cycle = _on_screen(app)
            expected = offsets_text([cycle], "siemens", _opened(app).current)
            number = derived_program_number(cycle.part.report, cycle.part.part)
            assert screen.text == expected and f"_N_SETUPFIX_{number}_MPF" in expected and "cycle 03" in expected
            await pilot.press("ctrl+s")
            await settle(pilot)
            assert (tmp_path / "offsets.mpf").read_text(encoding="utf-8") == expected
            assert any(
                n.message == f"wrote siemens offsets (program {number}) to {tmp_path / 'offsets.mpf'}"
                for n in app._notifications
            )
            # a controller that cannot hold the rotation: refused, named, nothing written
            await pilot.press("e")
            await pilot.pause()
            app.screen.query_one("#export-controller", Select).value = "fanuc"
            await pilot.pause()
            await pilot.press("ctrl+s")
            await pilot.pause()
            rotated = [k for k, v in cycle.corrections.items() if k.endswith(".C") and v != 0]
            assert rotated  # the case needs a rotation to refuse
            assert any(n.title == "export refused" and rotated[0] in n.message for n in app._notifications), [
                (n.title, n.message) for n in app._notifications
            ]
            assert not (tmp_path / "offsets.nc").exists()

    run(scenario())


@pytest.mark.slow
def test_switching_the_model_re_reads_current_and_a_mismatch_is_a_message(
    make_app: MakeApp, tmp_path: Path, two_models: tuple[Path, Path, Path]
) -> None:
    model, without, current = two_models

    async def scenario() -> None:
        app = make_app(report=XYZ / "cycle_01.csv", model=model, current=current)
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(pilot)
            c = app.state.current()
            assert c is not None and app.current_problem == "" and _opened(app).current is not None
            regs = {r[1]: r for r in _rows(app.query_one("#registers", DataTable))}
            assert regs["W1.X"][4] == "-400.000" and regs["W1.C"][4] == "+0.0000"
            assert regs["W1.X"][5] == f"{-400.0 + c.corrections['W1.X']:+.3f}"
            # another model: the file names a rotation that model does not have — said in one line, not fatal
            app.controller.model_picked(without)
            await settle(pilot)
            c = app.state.current()
            assert c is not None and app.is_running, [n.message for n in app._notifications]
            assert c.model.source.endswith("no_rotation.toml") and "W1.C" not in c.corrections
            assert _opened(app).current is None
            problem = app.current_problem
            assert problem.startswith("--current does not fit no_rotation.toml: ") and str(current) in problem
            assert "\n" not in problem
            assert any(n.title == "current offsets" and n.message == problem for n in app._notifications)
            assert "--current does not fit" in "\n".join(_screen(app))  # on the first screen, not only a toast
            regs = {r[1]: r for r in _rows(app.query_one("#registers", DataTable))}
            assert "W1.C" not in regs and regs["W1.X"][4] == "—"
            # without a rotation Fanuc holds the correction: changes (G91), named by the derived program number
            await pilot.press("e")
            await pilot.pause()
            app.screen.query_one("#export-controller", Select).value = "fanuc"
            await pilot.pause()
            expected = offsets_text([c], "fanuc")
            number = derived_program_number(c.part.report, c.part.part)
            assert _export(app).text == expected and f"O{number}" in expected
            await pilot.press("ctrl+s")
            await settle(pilot)
            assert (tmp_path / "offsets.nc").read_text(encoding="utf-8") == expected
            assert any(
                n.message == f"wrote fanuc offsets (program {number}) to {tmp_path / 'offsets.nc'}"
                for n in app._notifications
            )
            # back to the model it fits: read again, absolute values again
            app.controller.model_picked(model)
            await settle(pilot)
            assert app.current_problem == "" and _opened(app).current is not None
            assert "--current does not fit" not in "\n".join(_screen(app))

    run(scenario())


def test_the_current_option_s_help_names_the_multi_axis_form(capsys: pytest.CaptureFixture[str]) -> None:
    from setupfix.cli import main

    code: int | str | None
    try:
        code = main(["tui", "--help"])
    except SystemExit as exc:  # argparse's way out of --help, when main lets it through
        code = exc.code
    assert code in (0, None)
    text = " ".join(capsys.readouterr().out.split())
    assert "register,axis,value" in text and "register,value" in text
