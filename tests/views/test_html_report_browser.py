"""The HTML pages in a real browser: headless Chromium (Debian's package) driven by Playwright.

Locally a missing browser or Playwright skips with the reason; under CI (``CI=true``) it fails:
``.ci/chromium`` installs both.  The browser is launched from ``/usr/bin/chromium`` (no browser
download), with a fresh profile and without background networking; the page must load without a
console error, make no request but for itself, show its charts (coloured pixels inside the
chart's box on the screenshot) and print on A4.
"""

from __future__ import annotations

import io
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from spc_examples import GUIDE_PINS, closed_loop_store

from setupfix.store import open_store
from setupfix.usecases.correct import correct_report, load_request
from setupfix.usecases.spc_report import SpcRequest, spc_report
from setupfix.views.html import correction_page, spc_page

CHROMIUM = os.environ.get("SETUPFIX_CHROMIUM", "/usr/bin/chromium")
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _missing() -> str | None:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the Python package playwright is not installed (.ci/chromium installs it)"
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        return f"no Chromium at {CHROMIUM} (.ci/chromium installs Debian's chromium)"
    try:
        import PIL  # noqa: F401
    except ImportError:
        return "Pillow is not installed"
    return None


@pytest.fixture(scope="module")
def playwright() -> Iterator[Any]:
    why = _missing()
    if why:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI needs the browser test: {why}")
        pytest.skip(why)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        yield p


def render(playwright: Any, page_html: str, folder: Path, shot: Path | None = None) -> dict[str, Any]:
    """Open the page in a fresh Chromium profile; its errors, requests, chart screenshots and A4 PDF."""
    target = folder / "page.html"
    target.write_text(page_html, encoding="utf-8")
    profile = folder / "profile"
    context = playwright.chromium.launch_persistent_context(
        str(profile), executable_path=CHROMIUM, args=ARGS, headless=True, viewport={"width": 900, "height": 1300}
    )
    try:
        page = context.new_page()
        errors: list[str] = []
        requests: list[str] = []
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("requestfailed", lambda r: errors.append(f"failed {r.url}"))
        page.on("request", lambda r: requests.append(r.url))
        page.goto(target.as_uri(), wait_until="load")
        charts = []
        for selector in ("svg.individuals", "svg.moving-range", "svg.zone"):
            element = page.query_selector(selector)
            charts.append((selector, None if element is None else element.screenshot()))
        if shot is not None:
            page.screenshot(path=str(shot))
        pdf = page.pdf(format="A4")
        return {"errors": errors, "requests": requests, "url": target.as_uri(), "charts": charts, "pdf": pdf}
    finally:
        context.close()


def coloured(png: bytes) -> dict[str, int]:
    """Pixels of the chart's colours in a screenshot: data blue (measured), purple (predicted), limit red,
    zone green, and all non-white."""
    from PIL import Image

    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    white = ((r == 255) & (g == 255) & (b == 255)) | ((r == 250) & (g == 250) & (b == 250))
    return {
        "ink": int((~white).sum()),
        "blue": int(((b > 150) & (r < 90) & (g < 150)).sum()),
        "purple": int(((b > 190) & (r > 100) & (r < 160) & (g < 110)).sum()),
        "red": int(((r > 180) & (g < 80) & (b < 80)).sum()),
        "green": int(((g > 200) & (r < 235) & (b < 235) & (g > r + 10)).sum()),
    }


def check(result: dict[str, Any], chart_selectors: tuple[str, ...]) -> None:
    assert result["errors"] == []
    assert set(result["requests"]) == {result["url"]}  # the page itself, nothing else
    for selector, png in result["charts"]:
        if selector not in chart_selectors:
            continue
        assert png is not None, f"{selector} not on the page"
        c = coloured(png)
        assert c["ink"] > 2000, (selector, c)
        assert c["blue"] > 100, (selector, c)  # the data drawn
    pdf = result["pdf"]
    assert pdf.startswith(b"%PDF")
    boxes = {tuple(float(v) for v in box.split()) for box in re.findall(rb"/MediaBox \[([^\]]*)\]", pdf)}
    assert boxes and all(abs(w - 595.3) < 2 and abs(h - 841.9) < 2 for _, _, w, h in boxes), boxes  # A4 in pt


def test_spc_page_renders_in_chromium(playwright: Any, tmp_path: Path) -> None:
    db = closed_loop_store(tmp_path)
    with open_store(db) as store:
        outcome = spc_report(store, SpcRequest(dimensions=("P1 D1", "P3 D4")))
    result = render(playwright, spc_page(outcome), tmp_path, tmp_path / "spc.png")
    check(result, ("svg.individuals", "svg.moving-range", "svg.zone"))
    individuals = dict(result["charts"])["svg.individuals"]
    assert coloured(individuals)["red"] > 50  # limits and the flagged points of the drifting loop
    assert (tmp_path / "spc.png").stat().st_size > 10_000


def test_correction_page_renders_in_chromium(playwright: Any, tmp_path: Path) -> None:
    outcome = correct_report(load_request(GUIDE_PINS / "model.toml"), GUIDE_PINS / "cycle_01.csv")
    result = render(playwright, correction_page(outcome), tmp_path)
    check(result, ("svg.zone",))
    zone = coloured(dict(result["charts"])["svg.zone"])
    assert zone["green"] > 1000  # the tolerance bands
    assert zone["purple"] > 28 * 10  # a predicted diamond on each of the 28 dimensions
