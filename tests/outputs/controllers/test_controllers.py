"""Controller formats: golden files, absolute output is idempotent, inexpressible registers refused.

Regenerate the goldens after a deliberate change with
``PYTHONPATH=. python tests/outputs/controllers/test_controllers.py`` and review the diff.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from parsers.current import read_current
from setupfix.core.errors import ExportError
from setupfix.correction.offsets import OffsetRow, offset_rows
from setupfix.model import load_model, model_from_dict
from setupfix.outputs.controllers import CONTROLLERS, render
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest, SolveOptions

ROOT = Path(__file__).resolve().parents[3]
SAMPLE = ROOT / "sample_reports" / "controllers"
GOLDEN = Path(__file__).resolve().parent / "golden"


MODEL = load_model(SAMPLE / "model.toml")
# Fixed corrections (those `correct` found on report.csv when the goldens were made), so
# that the goldens test the formats, not the optimiser.
CORRECTIONS = {"W1": -0.022, "W2": 0.022, "T5": -0.008, "T12": 0.002}


def rows(mode: str) -> list[OffsetRow]:
    current = read_current(SAMPLE / "current.csv", MODEL) if mode == "set" else None
    return offset_rows(MODEL, CORRECTIONS, report="report.csv", part="cycle 7", current=current, verdict="apply")


def test_sample_report_gives_those_corrections() -> None:
    # the README's numbers: the paper's objective (issue 22 made leximin the default)
    (pc,) = correct_report(CorrectRequest(MODEL, solve=SolveOptions(objective="paper")), SAMPLE / "report.csv").cycles
    assert pc.verdict == "apply" and pc.margin_after == pytest.approx(0.048)
    assert pc.corrections == pytest.approx(CORRECTIONS)  # T12 (cost 3) moves least


CASES = [(name, mode) for name in CONTROLLERS for mode in ("add", "set") if (name, mode) != ("heidenhain", "add")]


@pytest.mark.parametrize(("name", "mode"), CASES)
def test_golden(name: str, mode: str) -> None:
    text = render(name, rows(mode), "report.csv cycle 7")
    assert text == (GOLDEN / f"{name}_{mode}.txt").read_text(encoding="utf-8")


def fanuc_state(program: str, state: dict[tuple[int, int], float]) -> dict[tuple[int, int], float]:
    """Run the G10 blocks of a program on a register state (a tiny G10 interpreter)."""
    out = dict(state)
    for m in re.finditer(r"^(G9[01]) G10 L(\d+) P(\d+) [ZR]([-+][\d.]+)", program, re.MULTILINE):
        key, value = (int(m.group(2)), int(m.group(3))), float(m.group(4))
        out[key] = value if m.group(1) == "G90" else out.get(key, 0.0) + value
    return out


def siemens_state(program: str, state: dict[str, float]) -> dict[str, float]:
    out = dict(state)
    for m in re.finditer(r"^(\$[^=]+)=(?:\1)?([-+][\d.]+)", program, re.MULTILINE):
        incremental = m.group(0).count(m.group(1)) == 2
        out[m.group(1)] = (out.get(m.group(1), 0.0) if incremental else 0.0) + float(m.group(2))
    return out


@pytest.mark.parametrize("name", ["fanuc", "haas"])
def test_absolute_program_is_idempotent_and_incremental_is_not(name: str) -> None:
    start = {(2, 1): -412.53, (2, 2): -412.487, (11, 5): -0.012, (11, 12): 0.0035}
    absolute = render(name, rows("set"))
    once = fanuc_state(absolute, start)
    assert fanuc_state(absolute, once) == once
    assert once[(2, 1)] == pytest.approx(-412.552) and once[(11, 12)] == pytest.approx(0.0055)
    incremental = render(name, rows("add"))
    once_inc = fanuc_state(incremental, start)
    assert once_inc == pytest.approx(once)  # same result the first time …
    assert fanuc_state(incremental, once_inc)[(2, 1)] == pytest.approx(-412.574)  # … doubled the second time


def test_siemens_absolute_is_idempotent() -> None:
    program = render("siemens", rows("set"))
    once = siemens_state(program, {})
    assert siemens_state(program, once) == once and once["$TC_DP12[5,1]"] == pytest.approx(-0.020)
    inc = render("siemens", rows("add"))
    assert siemens_state(inc, siemens_state(inc, once))["$P_UIFR[1,Z,TR]"] == pytest.approx(-412.552 - 0.044)


def test_current_finer_than_the_grid_is_kept(tmp_path: Path) -> None:
    model = load_model(SAMPLE / "model.toml")
    (tmp_path / "c.csv").write_text("register,value\nG54,-412.53046\nG55,0\nH5,0\nT12,0\n")
    current = read_current(tmp_path / "c.csv", model)
    (row, *_) = offset_rows(model, {"W1": -0.022}, current=current)
    assert row.cells()[10:12] == ["-412.53046", "-412.55246"]


TINY = {
    "process": {"name": "t"},
    "wks": {"W1": {"register": "G54.1P7"}},
    "tools": {"T1": {"register": "T3 D2"}},
    "features": {"F": {"wks": {"W1": 1}, "tools": {"T1": 1}}},
    "dimensions": {"D": {"features": {"F": 1}, "nominal": 1, "lower": -0.1, "upper": 0.1}},
}


@pytest.mark.parametrize(("name", "register"), [("haas", "G54.1P7"), ("siemens", "G54.1P7"), ("fanuc", "T3 D2")])
def test_inexpressible_register_is_named(name: str, register: str) -> None:
    model = model_from_dict(TINY)
    with pytest.raises(ExportError, match=f"{name}: cannot express register '{re.escape(register)}'"):
        render(name, offset_rows(model, {"W1": 0.01, "T1": 0.0}))


def test_heidenhain_needs_current_and_siemens_reads_t_d() -> None:
    model = model_from_dict(TINY)
    with pytest.raises(ExportError, match="--current"):
        render("heidenhain", offset_rows(model, {}))
    tool = offset_rows(model, {"T1": -0.004})[1:]
    assert "$TC_DP12[3,2]=$TC_DP12[3,2]-0.004" in render("siemens", tool)
    assert "G91 G10 L20 P7 Z+0.010" in render("fanuc", offset_rows(model, {"W1": 0.01})[:1])


if __name__ == "__main__":  # regenerate the goldens
    GOLDEN.mkdir(parents=True, exist_ok=True)
    for name, mode in CASES:
        (GOLDEN / f"{name}_{mode}.txt").write_text(render(name, rows(mode), "report.csv cycle 7"), encoding="utf-8")
    sys.exit(0)
