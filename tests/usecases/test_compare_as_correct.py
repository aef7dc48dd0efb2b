"""``compare`` poses ``correct``'s problem (issue 37 item 7): the same request, history and current offsets
included, so its exact yardstick is ``correct``'s raw optimum (paper objective) on the same inputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main
from setupfix.usecases.compare import CompareRequest, compare_report
from setupfix.usecases.correct import correct_report, load_request
from setupfix.usecases.requests import SolveOptions

REGISTERS = ("G54", "G55", "G56", "G57", "G58", "G59", "G54.1P1", "G54.1P2")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """Guide pins with wear tools, ``ewma = 0.4`` and a cumulative limit; a store of cycles 1–3; current
    offsets with both tools near that limit (so the bounds bind)."""
    tmp = tmp_path_factory.mktemp("compare")
    text = (GUIDE_PINS / "model.toml").read_text()
    for tool, reg in (("T5", "H5"), ("T23", "H23")):
        old = f'[tools.{tool}]\nregister = "{reg}"'
        assert old in text
        text = text.replace(old, f'{old}\noffset = "wear"')
    model = tmp / "model.toml"
    model.write_text(text + "\n[safety]\newma = 0.4\ncumulative_limit = 0.05\n")
    db = tmp / "history.db"
    reports = [str(GUIDE_PINS / f"cycle_0{k}.csv") for k in range(1, 4)]
    assert main(["history", "import", "--db", str(db), "--model", str(model), *reports]) == 0
    current = tmp / "current.csv"
    current.write_text("register,value\n" + "".join(f"{r},-400.5\n" for r in REGISTERS) + "H5,-0.049\nH23,0.045\n")
    return model, db, current


@pytest.mark.parametrize("cycle", [4, 5])
@pytest.mark.parametrize("with_store", [False, True])
@pytest.mark.parametrize("with_current", [False, True])
def test_compare_exact_is_corrects_raw_optimum(
    inputs: tuple[Path, Path, Path], cycle: int, with_store: bool, with_current: bool
) -> None:
    model, db, current = inputs
    report = GUIDE_PINS / f"cycle_0{cycle}.csv"
    request = load_request(
        model,
        solve=SolveOptions(objective="paper"),
        store=db if with_store else None,
        current=current if with_current else None,
    )
    raw = correct_report(request, report).cycles[0].recommendation.result
    exact = compare_report(CompareRequest(request, methods=(), trials=1), report).exact
    np.testing.assert_array_equal(exact.x, raw.x)
    assert (exact.margin_after, exact.norm, exact.status) == (raw.margin_after, raw.norm, raw.status)
    if with_store or with_current:  # the inputs change the problem: a compare without them answers otherwise
        plain = compare_report(CompareRequest(model, methods=(), trials=1), report).exact
        assert not np.array_equal(plain.x, exact.x)


def test_cli_compare_takes_the_store_and_the_current_offsets(
    inputs: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    model, db, current = inputs
    report = GUIDE_PINS / "cycle_05.csv"
    argv = ["--model", str(model), "--store", str(db), "--current", str(current), "--json", str(report)]
    assert main(["correct", *argv, "--objective", "paper"]) == 0
    corrected = json.loads(capsys.readouterr().out)
    code = main(["compare", *argv, "--trials", "1"])
    out, err = capsys.readouterr()
    assert code == 0, err
    compared = json.loads(out)
    request = load_request(model, solve=SolveOptions(objective="paper"), store=db, current=current)
    raw = correct_report(request, report).cycles[0].recommendation.result
    assert compared["exact_margin"] == pytest.approx(raw.margin_after, abs=1e-9)
    assert compared["exact_norm"] == pytest.approx(raw.norm, abs=1e-9)
    assert corrected["verdict"] == "apply"
    applied = np.array([corrected["corrections"][r.id] for r in request.model.registers])
    np.testing.assert_allclose(applied, raw.x, atol=1e-9)  # correct applies its raw optimum here: one answer
