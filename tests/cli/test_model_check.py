"""``setupfix model check``: the match table, suggestions both ways, in full as JSON."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main

MODEL = str(GUIDE_PINS / "model.toml")


def renamed(tmp_path: Path, old_new: list[tuple[str, str]]) -> Path:
    text = (GUIDE_PINS / "cycle_01.csv").read_text(encoding="utf-8")
    for old, new in old_new:
        text = text.replace(f"\n{old},", f"\n{new},")
    path = tmp_path / "r.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_check_lists_unmatched_with_closest_and_absent_with_closest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = renamed(tmp_path, [("P2 D3", "P2-D3"), ("P1 D1", "P1D1"), ("P4 D7", "Flatness A")])
    assert main(["model", "check", MODEL, str(path)]) == 0
    out = capsys.readouterr().out
    assert "25 of 28 model dimensions matched, 3 report characteristic(s) unmatched" in out
    assert "  P2-D3  →  P2 D3" in out and "  P1D1  →  P1 D1" in out and "  Flatness A  (nothing close)" in out
    assert "P2 D3" in out and "absent from the report; closest report names: P2-D3" in out
    assert max(len(line) for line in out.splitlines()) <= 100
    assert main(["model", "check", MODEL, str(path), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    (part,) = obj["parts"]
    assert {u["name"]: u["closest"][:1] for u in part["unmatched"]} == {
        "P1D1": ["P1 D1"],
        "P2-D3": ["P2 D3"],
        "Flatness A": [],
    }
    row = next(r for r in part["dimensions"] if r["id"] == "P1D2")
    assert row["characteristic"] == "P1 D2" and row["report_nominal"] == 40.0 and row["station"] == "P1"
    assert row["source"].endswith("r.csv:3") and row["differs"] is False


def test_correct_json_lists_suggestions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = renamed(tmp_path, [("P2 D3", "P2-D3")])
    assert main(["correct", "--model", MODEL, "--json", str(path)]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["unmatched"] == ["P2-D3"] and obj["suggestions"] == {"P2-D3": ["P2 D3"]}


def test_check_marks_differences_and_strict_refuses(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = (
        (GUIDE_PINS / "cycle_01.csv")
        .read_text(encoding="utf-8")
        .replace("P1 D4,30.0000,29.9253", "P1 D4,31.0000,30.9253")
    )
    path = tmp_path / "r.csv"
    path.write_text(text, encoding="utf-8")
    assert main(["model", "check", MODEL, str(path)]) == 0
    out = capsys.readouterr().out
    (line,) = [x for x in out.splitlines() if x.startswith("P1      P1 D4")]
    assert line.endswith("≠") and "warning:" in out and "nominal 31 mm differs from the model's 30 mm" in out
    assert main(["model", "check", MODEL, str(path), "--strict"]) == 1
    assert "refused by --strict" in capsys.readouterr().err


def test_wide_characters_keep_columns_aligned() -> None:
    from setupfix.cli.model import cells, cut

    assert cells("원통1(I).D") == 10 and cut("원통1(I).D", 12) == "원통1(I).D  "
    assert cells(cut("원통1(I).D", 7)) == 7 and cut("원통1(I).D", 7).endswith("…")
    assert cut("a\x1b[31mb", 8) == "a?[31mb "  # control characters never reach the terminal


def test_init_never_overwrites_an_edited_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "model.toml"
    out.write_text("# edited by hand\n", encoding="utf-8")
    report = str(GUIDE_PINS / "cycle_01.csv")
    assert main(["model", "init", report, "-o", str(out)]) == 1
    assert "exists" in capsys.readouterr().err and out.read_text(encoding="utf-8") == "# edited by hand\n"
    assert main(["model", "init", report, "-o", str(out), "--force"]) == 0
    assert "[dimensions.D28]" in out.read_text(encoding="utf-8")


def test_hostile_report_names_do_not_reach_the_terminal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = renamed(tmp_path, [("P2 D3", "P2\x1b[2JD3")])
    assert main(["model", "check", MODEL, str(path)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and ("P2?[2JD3" in out or "P2\\x1b[2JD3" in out)  # masked here or by the reader
