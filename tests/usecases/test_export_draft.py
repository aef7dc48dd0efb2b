"""A draft model writes no program (issue 37, item 16 f): every controller format is refused with one line naming
the model, with and without the current offsets, and nothing is written; the offsets CSV keeps its hold rows.

A variant of the issue's case (``correct --controller fanuc --offsets``): the two-station sample made a draft,
every program format, through the use case and through the CLI.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import SAMPLES

from setupfix.cli import main
from setupfix.core.errors import ExportError
from setupfix.model import load_model
from setupfix.outputs.controllers import CONTROLLERS
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import export, offsets_text
from setupfix.usecases.requests import CorrectRequest, CurrentOffsets

CONTROLLERS_SAMPLE = SAMPLES / "controllers"
PROGRAMS = [c for c in CONTROLLERS if c != "csv"]


def draft_model(tmp_path: Path) -> Path:
    text = (CONTROLLERS_SAMPLE / "model.toml").read_text(encoding="utf-8")
    path = tmp_path / "draft.toml"
    path.write_text(text.replace("[process]\n", "[process]\ndraft = true\n", 1), encoding="utf-8")
    return path


@pytest.mark.parametrize("controller", PROGRAMS)
@pytest.mark.parametrize("with_current", [False, True])
def test_a_draft_model_writes_no_program(tmp_path: Path, controller: str, with_current: bool) -> None:
    model = load_model(draft_model(tmp_path))
    assert model.draft
    (cycle,) = correct_report(CorrectRequest(model), CONTROLLERS_SAMPLE / "report.csv").cycles
    current = CurrentOffsets.read(CONTROLLERS_SAMPLE / "current.csv", model) if with_current else None
    target = tmp_path / "out.prog"
    with pytest.raises(ExportError) as info:
        export([cycle], str(target), controller=controller, current=current)
    assert "draft" in str(info.value) and str(tmp_path / "draft.toml") in str(info.value)
    assert not target.exists()
    with pytest.raises(ExportError):
        offsets_text([cycle], controller, current)
    # the CSV still says what the draft holds: every row a hold of zero
    rows = offsets_text([cycle], "csv", current).splitlines()[1:]
    assert rows and all(r.endswith(",hold") for r in rows)


@pytest.mark.parametrize("current", [False, True])
def test_correct_refuses_the_program_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], current: bool
) -> None:
    target = tmp_path / "draft.nc"
    args = ["correct", "--model", str(draft_model(tmp_path)), "--controller", "haas", "--offsets", str(target)]
    if current:
        args += ["--current", str(CONTROLLERS_SAMPLE / "current.csv")]
    code = main([*args, str(CONTROLLERS_SAMPLE / "report.csv")])
    err = capsys.readouterr().err
    assert code != 0 and not target.exists()
    refusal = [line for line in err.splitlines() if "no program is written" in line]
    assert len(refusal) == 1 and "Traceback" not in err and "internal error" not in err
