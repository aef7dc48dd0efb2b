"""``setupfix replay`` at the door: JSON per the contract, one-line refusals, marked reports left out, the page
in headless Chromium."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from usecases.test_replay import MODEL, USED, closed_loop, drifting, store_loop
from views.test_html_report_browser import check, playwright, render

from setupfix.cli import main
from setupfix.cli.exit_codes import ERROR, USAGE
from setupfix.store import open_store
from setupfix.usecases.parse import parse_reports
from setupfix.usecases.replay import ReplayRequest, replay_history, replay_json
from setupfix.views.replay_html import replay_page

__all__ = ["playwright"]


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = drifting(30, seed=3)
    parts, moves = closed_loop(base, USED)
    target = tmp_path_factory.mktemp("doors") / "loop.db"
    store_loop(target, parts, moves)
    return target


RULES = "dead_band=10 %,gain=0.5,mean_of=3"


@pytest.mark.slow
def test_json_is_the_use_case_and_the_contract(db: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", "--db", str(db), "--model", str(MODEL), "--rules", RULES, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {"parts", "actual", "replayed", "rules"} <= set(doc)
    for side in ("actual", "replayed"):
        assert {"out_of_tolerance", "corrections", "cpk"} <= set(doc[side])
        assert set(doc[side]["cpk"]) >= {"P1 D1"}
    assert doc["rules"]["dead_band"] == "10 %" and doc["rules"]["gain"] == 0.5 and doc["rules"]["mean_of"] == 3
    assert doc == replay_json(replay_history(ReplayRequest(db, MODEL, USED)))
    assert doc["actual"] == doc["replayed"]  # the rule used, replayed
    assert "assumes the model" in doc["assumption"]
    assert doc["walk_forward_centre_rms"] is not None  # 30 parts: the walk forward is computed


@pytest.mark.parametrize(
    ("args", "status", "said"),
    [
        (["--rules", "dead_band=ten"], ERROR, "dead_band"),
        (["--grid", "gain=0.5|x"], ERROR, "--grid"),
        (["--grid", "speed=1"], ERROR, "--grid"),
        (["--rules"], USAGE, "--rules"),
    ],
)
def test_bad_rules_or_grid_are_one_line(
    db: Path, capsys: pytest.CaptureFixture[str], args: list[str], status: int, said: str
) -> None:
    assert main(["replay", "--db", str(db), "--model", str(MODEL), *args]) == status
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and said in err and "Traceback" not in err


def test_no_store_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", "--db", str(tmp_path / "none.db"), "--model", str(MODEL)]) == ERROR
    assert "no history store" in capsys.readouterr().err


@pytest.mark.slow
def test_marked_reports_stay_out(tmp_path: Path) -> None:
    base = drifting(20, seed=5)
    parts, moves = closed_loop(base, USED)
    target = tmp_path / "marked.db"
    store_loop(target, parts, moves)
    sample = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins" / "cycle_02.csv"
    with open_store(target) as store:
        table = parse_reports([sample]).table
        table["timestamp"] = "2026-05-04T06:10:00"
        store.add_report(b"rejected one", "bad.csv", "canonical", table, excluded="rejected")
    kept = replay_history(ReplayRequest(target, MODEL, USED, walk=False))
    taken = replay_history(ReplayRequest(target, MODEL, USED, walk=False, include_excluded=True))
    assert len(kept.parts) == 20 and kept.excluded == 1 and len(taken.parts) == 21
    assert np.array_equal(kept.trace.deviation, kept.measured, equal_nan=True)


@pytest.mark.slow
def test_page_renders_in_chromium(playwright: Any, db: Path, tmp_path: Path) -> None:
    outcome = replay_history(ReplayRequest(db, MODEL, USED, grid=True, grid_values=((None, 0.1), (0.5, 1.0), (1,))))
    page = replay_page(outcome)
    assert "assumes the model" in page and "walk-forward" in page and "(best)" in page
    result = render(playwright, page, tmp_path)
    check(result, ())
    assert page.count('class="chart replay-before"') == page.count('class="chart replay-after"') >= 1
