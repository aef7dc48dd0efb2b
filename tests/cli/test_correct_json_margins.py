"""``correct --json`` in a triage (issue 37 item 5): ``margin_before``/``margin_after`` are f1 over ALL
dimensions (``../shared/spec/cli-json.md``), the kept set's budget sits under ``margin_kept_*``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from setupfix.cli import main

MODEL = """\
[process]
name = "triage"
resolution = 0.001
limit = 0.1

[safety]
reject_band = 5.0

[wks.W1]
register = "G54"

[tools.T1]
register = "H1"

[features.F1]
wks = { W1 = 1 }

[features.F2]
wks = { W1 = 1 }
tools = { T1 = 1 }

[dimensions.A]
name = "Bore A"
features = { F1 = 1 }
nominal = 10
lower = -0.05
upper = 0.05

[dimensions.B]
name = "Bore B"
features = { F1 = 1 }
nominal = 20
lower = -0.05
upper = 0.05

[dimensions.C]
name = "Depth C"
features = { F2 = 1 }
nominal = 30
lower = -0.05
upper = 0.05
"""


@pytest.mark.parametrize(("a", "b"), [(10.12, 19.96), (10.14, 19.97), (9.87, 20.03)])
def test_margins_are_over_every_dimension_and_the_kept_set_apart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], a: float, b: float
) -> None:
    """A and B share one feature but lie 0.16 mm or more apart on ±0.05: one is given up outside its limits."""
    model, report = tmp_path / "model.toml", tmp_path / "r.csv"
    model.write_text(MODEL, encoding="utf-8")
    report.write_text(f"characteristic,nominal,actual\nBore A,10,{a}\nBore B,20,{b}\nDepth C,30,30.03\n")
    code = main(["correct", "--model", str(model), "--json", str(report)])
    out, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "apply" and len(doc["given_up"]) == 1
    rows = doc["dimensions"]
    given_up = [r for r in rows if "given_up" in r["flags"]]
    kept = [r for r in rows if "given_up" not in r["flags"]]
    assert doc["margin_after"] == pytest.approx(min(r["margin"] for r in rows), abs=1e-9)
    assert doc["margin_after"] < 0  # a given-up dimension stays out: not "all in"
    assert doc["margin_after"] == pytest.approx(given_up[0]["margin"], abs=1e-9)
    assert doc["margin_kept_after"] == pytest.approx(min(r["margin"] for r in kept), abs=1e-9)
    assert doc["margin_kept_after"] > 0
    before = [min(r["deviation"] - r["lower"], r["upper"] - r["deviation"]) for r in rows]
    assert doc["margin_before"] == pytest.approx(min(before), abs=1e-9)
    assert doc["bonus"] == pytest.approx(doc["margin_after"] - doc["margin_before"], abs=1e-9)
    assert doc["in_tolerance"] is False


def test_the_html_page_gives_both_budgets_in_a_triage(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model, report, page = tmp_path / "model.toml", tmp_path / "r.csv", tmp_path / "r.html"
    model.write_text(MODEL, encoding="utf-8")
    report.write_text("characteristic,nominal,actual\nBore A,10,10.13\nBore B,20,19.96\nDepth C,30,30.02\n")
    code = main(["correct", "--model", str(model), "--html", str(page), str(report)])
    assert code == 0, capsys.readouterr().err
    capsys.readouterr()
    doc = json.loads(_json(model, report, capsys))
    text = page.read_text(encoding="utf-8")
    assert f"after {doc['margin_kept_after']:+.4f} mm over the dimensions kept" in text
    assert f"over every dimension before {doc['margin_before']:+.4f} mm, after {doc['margin_after']:+.4f} mm" in text


def _json(model: Path, report: Path, capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["correct", "--model", str(model), "--json", str(report)]) == 0
    return capsys.readouterr().out
