"""``correct --html``: one self-contained page of the correction, with the stored series' charts given --store."""

from __future__ import annotations

from pathlib import Path

import pytest
from spc_examples import GUIDE_PINS, closed_loop_store
from views.test_html_report import EXTERNAL, tags

from setupfix.cli import main


def test_page_of_a_correction_with_and_without_history(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["correct", "--model", str(GUIDE_PINS / "model.toml"), str(GUIDE_PINS / "cycle_01.csv")]
    page = tmp_path / "c.html"
    assert main([*args, "--html", str(page)]) == 0
    text = page.read_text(encoding="utf-8")
    assert not EXTERNAL.search(text) and tags(text).count.get("svg", 0) >= 1
    assert "APPLY" in text and "G54" in text and 'class="chart individuals"' not in text
    (tmp_path / "loop").mkdir()
    db = closed_loop_store(tmp_path / "loop")
    assert main([*args, "--html", str(page), "--store", str(db)]) == 0
    assert 'class="chart individuals"' in page.read_text(encoding="utf-8")  # the stored series' control charts


def test_unwritable_page_is_refused_before_any_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["correct", "--model", str(GUIDE_PINS / "model.toml"), str(GUIDE_PINS / "cycle_01.csv")]
    assert main([*args, "--html", str(tmp_path / "no" / "c.html")]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "does not exist" in err
