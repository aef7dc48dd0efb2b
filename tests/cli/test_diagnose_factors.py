"""``setupfix diagnose --factors``: declared design factors from the command line, and bad declarations."""

from __future__ import annotations

import json

import pytest
from diagnose.test_plate import LOG, MODEL, PLATE, needs_log

from setupfix.cli import main

DESIGN = "doe_tool_length,doe_speed,doe_tool_length*doe_speed"


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
@needs_log
def test_factors_are_tested_listed_and_marked_declared(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        capsys, "diagnose", "--model", MODEL, "--process", LOG, "--factors", DESIGN, "--no-walk", PLATE
    )
    assert code == 0, err
    assert "declared factors (15 tests" in out
    line = next(ln for ln in out.splitlines() if ln.lstrip().startswith("doe_tool_length*doe_speed") and "T5A" in ln)
    assert line.rstrip().endswith("accepted")
    t4a = next(ln for ln in out.splitlines() if ln.lstrip().startswith("doe_tool_length*doe_speed") and "T4A" in ln)
    assert "accepted" not in t4a
    assert "T5A ~ doe_tool_length=Long & doe_speed=Low" in out and "declared, p " in out
    code, out, err = run(
        capsys, "diagnose", "--model", MODEL, "--process", LOG, "--factors", DESIGN, "--no-walk", "--json", PLATE
    )
    assert code == 0, err
    doc = json.loads(out)
    rows = {(r["term"], r["register"]): r for r in doc["declared_factors"]}
    t5a = rows[("doe_tool_length*doe_speed", "T5A")]
    assert t5a["accepted"] and t5a["df"] == 2
    assert not rows[("doe_tool_length*doe_speed", "T4A")]["accepted"]
    e = next(e for e in doc["effects"] if e["source"] == "declared" and e["p"] is not None)
    assert {"kind", "target", "estimate", "stderr", "unit", "channel", "register"} <= e.keys()


@needs_log
def test_an_unknown_factor_is_one_line_naming_it(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        capsys, "diagnose", "--model", MODEL, "--process", LOG, "--factors", "doe_tool_length,spindle_sped", PLATE
    )
    assert code != 0 and out == ""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "'spindle_sped'" in lines[0] and "plate_process.csv" in lines[0]
    assert "Traceback" not in err


@needs_log
def test_a_malformed_term_and_factors_without_a_log_are_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "diagnose", "--model", MODEL, "--process", LOG, "--factors", "a*a", PLATE)
    assert code != 0 and len(err.strip().splitlines()) == 1 and "a*a" in err
    code, _, err = run(capsys, "diagnose", "--model", MODEL, "--factors", "doe_speed", PLATE)
    assert code != 0 and len(err.strip().splitlines()) == 1 and "--process" in err
