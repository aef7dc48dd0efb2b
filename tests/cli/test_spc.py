"""``setupfix spc``: text, JSON and the HTML page from a store; bad input is one line and a non-zero exit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from spc_examples import closed_loop_store

from setupfix.cli import main


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return closed_loop_store(tmp_path_factory.mktemp("cli_spc"))


def test_json_and_html(db: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    page = tmp_path / "spc.html"
    code = main(
        [
            "spc",
            "--db",
            str(db),
            "--dimension",
            "P1 D1",
            "--dimension",
            "p2  d3",
            "--baseline",
            "10",
            "--json",
            "--html",
            str(page),
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    data = json.loads(out)
    assert [d["name"] for d in data["dimensions"]] == ["P1 D1", "P2 D3"]
    d = data["dimensions"][0]
    assert d["n"] == 40 and d["chart"]["baseline"] == 10
    assert d["cpk_ci95"][0] < d["cpk"] < d["cpk_ci95"][1]
    assert len(d["split_effects"]) == 7 and all(s["source"] == "correction" for s in d["split_effects"])
    assert page.read_text(encoding="utf-8").count('class="chart individuals"') == 2
    assert f"page → {page}" in err


def test_text_with_a_given_split(db: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["spc", "--db", str(db), "--dimension", "P1 D1", "--split", "2026-11-02T12:00:00"]) == 0
    out = capsys.readouterr().out
    assert "P1 D1" in out and "Cpk" in out
    assert "split 2026-11-02T12:00:00: Cpk" in out
    assert "correction 2026" not in out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--machine", "M1"], "no measurements stored for machine 'M1'"),
        (["--dimension", "nope"], "no stored characteristic 'nope'"),
        (["--since", "last week"], "--since: timestamp 'last week' is not ISO 8601"),
        (["--baseline", "1"], "--baseline: must be in [2,"),
    ],
)
def test_bad_input_is_one_line(
    db: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    page = tmp_path / "never.html"
    code = main(["spc", "--db", str(db), "--html", str(page), *args])
    err = capsys.readouterr().err
    assert code in (1, 2)
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not page.exists()


def test_a_missing_store_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["spc", "--db", str(tmp_path / "none.db")]) == 1
    err = capsys.readouterr().err
    assert "none.db" in err and "no history store here" in err
    assert not (tmp_path / "none.db").exists()


def test_the_page_alone_to_standard_output(db: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["spc", "--db", str(db), "--dimension", "P1 D1", "--html", "-"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("<!DOCTYPE html>") and out.rstrip().endswith("</html>")
    assert main(["spc", "--db", str(db), "--html", "-", "--json"]) == 1
    assert "both write to standard output" in capsys.readouterr().err
