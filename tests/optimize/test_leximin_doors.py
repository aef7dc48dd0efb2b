"""Leximin through the doors (issue 22): --objective on correct, SolveOptions, compare on the paper's objective."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main
from setupfix.core.errors import ParameterError
from setupfix.inputs.cycles import load_parts
from setupfix.model import load_model
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.usecases.compare import CompareRequest, compare_report
from setupfix.usecases.requests import SolveOptions

MODEL = str(GUIDE_PINS / "model.toml")
REPORT = str(GUIDE_PINS / "cycle_01.csv")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_objective_paper_reproduces_the_readme_example(capsys: pytest.CaptureFixture[str]) -> None:
    """README: δ after +0.0822 mm, bonus +0.0651 mm, correction norm 0.0410 mm, T23 +0.027."""
    code, out, err = run(capsys, "correct", "--objective", "paper", "--model", MODEL, REPORT)
    assert code == 0, err
    assert "error budget before +0.0171 mm, after +0.0822 mm, bonus +0.0651 mm; correction norm 0.0410 mm" in out
    assert "upper bound (continuous LP): +0.0824 mm" in out


def test_default_is_leximin_same_delta_every_other_margin_at_least_as_centred(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run(capsys, "correct", "--model", MODEL, "--json", REPORT)
    assert code == 0, err
    lex = json.loads(out)
    code, out, err = run(capsys, "correct", "--objective", "paper", "--model", MODEL, "--json", REPORT)
    paper = json.loads(out)
    assert lex["margin_after"] == pytest.approx(paper["margin_after"], abs=1e-9)  # level 1 is the paper's δ
    m_lex = sorted(min(d["upper"] - d["predicted"], d["predicted"] - d["lower"]) for d in lex["dimensions"])
    m_paper = sorted(min(d["upper"] - d["predicted"], d["predicted"] - d["lower"]) for d in paper["dimensions"])
    assert tuple(np.round(m_lex, 9)) > tuple(np.round(m_paper, 9))  # strictly better centred on this report
    assert lex.keys() == paper.keys()  # the contract's keys either way


def test_cli_refuses_leximin_for_a_metaheuristic_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "correct", "--optimizer", "pso", "--objective", "leximin", "--model", MODEL, REPORT)
    assert code != 0 and not out
    assert "leximin" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_solve_options_resolve_the_objective_per_optimizer() -> None:
    assert SolveOptions().resolved_objective == "leximin" and SolveOptions().params() == {}
    assert SolveOptions(objective="paper").params() == {"objective": "paper"}
    assert SolveOptions("pso", seed=1).resolved_objective == "paper"
    assert SolveOptions("pso", seed=1, objective="paper").params() == {}
    with pytest.raises(ParameterError, match="leximin"):
        SolveOptions("ga", objective="leximin")
    with pytest.raises(ParameterError, match="objective"):
        SolveOptions(objective="centre")


def test_compare_measures_the_metaheuristics_against_the_papers_optimum() -> None:
    comparison = compare_report(CompareRequest(MODEL, methods=(), trials=1), REPORT)
    model = load_model(MODEL)
    problem = CorrectionProblem.from_part(model, load_parts(model, GUIDE_PINS / "cycle_01.csv")[0])
    paper = get_optimizer("exact", objective="paper").solve(problem)
    np.testing.assert_array_equal(comparison.exact.x, paper.x)


@pytest.mark.parametrize("objective", ["paper", "leximin"])
def test_diagnose_next_correction_follows_the_objective(objective: str) -> None:
    """``diagnose --objective``: the next correction is ``correct``'s on the forecast with that objective."""
    from conftest import SAMPLES

    from setupfix.diagnose import Diagnoser
    from setupfix.model import PartMeasurement
    from setupfix.usecases.correct import correct_cycle
    from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports, forecast_model
    from setupfix.usecases.requests import CorrectRequest

    loop = SAMPLES / "closed_loop"
    solve = SolveOptions(objective=objective)
    out = diagnose_reports(
        DiagnoseRequest(
            GUIDE_PINS / "model.toml",
            (loop / "measurements.csv",),
            corrections=str(loop / "corrections.csv"),
            temperatures=str(loop / "temperatures.csv"),
            diagnoser=Diagnoser(walk=False),
            solve=solve,
        )
    )
    fc = out.diagnosis.forecast
    part = PartMeasurement(part="next", report="forecast", timestamp=None, deviation=fc, sources=tuple("" for _ in fc))
    again = correct_cycle(
        CorrectRequest(forecast_model(out.input.model), solve=solve), part, composite=out.diagnosis.relation_matrix()
    )
    assert out.next_cycle is not None
    np.testing.assert_array_equal(out.next_cycle.x, again.x)
