"""The capability page a quality engineer signs: baseline warning, labelled limits and parts, Cpk intervals with
"too few parts", every rule violation in a collapsible list -- in the HTML and in headless Chromium."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from spc_examples import closed_loop_store
from views.test_html_report_browser import CHROMIUM, check, playwright, render

from setupfix.store import open_store
from setupfix.usecases.spc_report import SpcOutcome, SpcRequest, spc_report
from setupfix.views.html import spc_page

__all__ = ["playwright"]


def _outcome(folder: Path) -> SpcOutcome:
    with open_store(closed_loop_store(folder)) as store:
        return spc_report(store, SpcRequest(dimensions=("P1 D1", "P3 D4")))


def test_page_warns_labels_and_lists_every_violation(tmp_path: Path) -> None:
    outcome = _outcome(tmp_path)
    page = spc_page(outcome)
    d = outcome.dimensions[0]
    # the warning of the baseline that spans corrections, in each section
    assert page.count('class="warning baseline"') == 2
    assert "spans 3 correction(s)" in page
    # limit lines carry their values
    assert f"UCL {d.limits.ucl:+.4f}" in page and f"LCL {d.limits.lcl:+.4f}" in page
    assert f"CL {d.limits.center:+.4f}" in page
    # parts along the axis, not only the first and last
    ticks = [int(t) for t in re.findall(r'class="tick">(\d+)<', page)]
    assert {1, 10, 20, 30, 40} <= set(ticks)
    # every violation listed, in <details>, nothing "… and N more"
    assert "more</" not in page and "… and" not in page
    for dim in outcome.dimensions:
        for rule in {v.rule for v in dim.violations}:
            count = sum(v.rule == rule for v in dim.violations)
            assert f"rule {rule} (" in page and f"{count} violation(s)</summary>" in page
    assert page.count("<details") == sum(len({v.rule for v in x.violations}) for x in outcome.dimensions)
    # the split Cpks: an interval and "too few parts"
    assert "too few parts (n &lt; 30)" in page


@pytest.mark.slow
def test_page_with_the_warning_renders_in_chromium(playwright: Any, tmp_path: Path) -> None:
    outcome = _outcome(tmp_path)
    result = render(playwright, spc_page(outcome), tmp_path, tmp_path / "spc.png")
    check(result, ("svg.individuals", "svg.moving-range", "svg.zone"))
    context = playwright.chromium.launch_persistent_context(
        str(tmp_path / "profile2"), executable_path=CHROMIUM, headless=True, args=["--no-sandbox"]
    )
    try:
        page = context.new_page()
        page.goto((tmp_path / "page.html").as_uri())
        warning = page.locator("p.warning.baseline").first
        assert warning.is_visible() and "spans 3 correction(s)" in warning.inner_text()
        box = warning.bounding_box()
        assert box is not None and box["height"] > 10
        details = page.locator("details.rules").first
        items = details.locator("li")
        assert not items.first.is_visible()  # closed until opened
        details.locator("summary").click()
        assert items.first.is_visible()
        n = outcome.dimensions[0].violations
        assert items.count() == sum(v.rule == n[0].rule for v in n)
        assert page.locator("svg.individuals text.tick").count() >= 5
    finally:
        context.close()
