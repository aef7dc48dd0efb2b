"""The HTML pages: self-contained, escaped, and holding what they say (charts, flags, registers)."""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from spc_examples import GUIDE_PINS, closed_loop_store

from setupfix.store import open_store
from setupfix.usecases.correct import correct_report, load_request
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.usecases.spc_report import SpcOutcome, SpcRequest, spc_report
from setupfix.views.html import correction_page, spc_page

#: What would make a page load something from elsewhere (the SVG namespace URI is a name, not a load).
EXTERNAL = re.compile(
    r"\b(src|href|action|poster|srcset)\s*=|url\(|@import|<script|<link|<iframe|<img|<object", re.IGNORECASE
)


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.bad: list[str] = []
        self.count: dict[str, int] = {}

    VOID = frozenset({"meta", "br", "hr", "img", "input", "link", "circle", "line", "rect", "path", "polyline"})

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.count[tag] = self.count.get(tag, 0) + 1
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.count[tag] = self.count.get(tag, 0) + 1

    def handle_endtag(self, tag: str) -> None:
        if tag in self.VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.bad.append(tag)
        else:
            self.stack.pop()


def tags(page: str) -> _Tags:
    parser = _Tags()
    parser.feed(page)
    parser.close()
    assert parser.bad == [] and parser.stack == [], (parser.bad, parser.stack)
    return parser


@pytest.fixture(scope="module")
def loop_spc(tmp_path_factory: pytest.TempPathFactory) -> SpcOutcome:
    db = closed_loop_store(tmp_path_factory.mktemp("loop"))
    with open_store(db) as store:
        return spc_report(store, SpcRequest(dimensions=("P1 D1", "P2 D3", "P4 D7")))


def test_spc_page_is_self_contained_and_well_formed(loop_spc: SpcOutcome) -> None:
    page = spc_page(loop_spc)
    assert page.startswith("<!DOCTYPE html>")
    assert not EXTERNAL.search(page)
    assert set(re.findall(r"https?://[^\s\"'<>]+", page)) == {"http://www.w3.org/2000/svg"}
    t = tags(page)
    assert t.count["svg"] == 3 * 3  # per dimension: tolerance zone, individuals, moving range
    assert "@page { size: A4" in page


def test_spc_page_marks_every_violating_point_and_lists_every_split(loop_spc: SpcOutcome) -> None:
    page = spc_page(loop_spc)
    charts = re.findall(r'<svg[^>]*class="chart individuals".*?</svg>', page, re.S)
    assert len(charts) == 3
    for d, svg in zip(loop_spc.dimensions, charts, strict=True):
        flagged = {i for v in d.violations for i in range(v.first, v.last + 1)}
        assert svg.count('fill="#cf222e"/>') == len(flagged)
        assert svg.count("<circle") == len(d.values)
        assert svg.count('stroke-dasharray="2 2"') == len(d.splits)
        assert len(d.splits) == 7  # the log's seven correction times inside the series
    for s in loop_spc.dimensions[0].splits:
        assert f"correction {s.time}" in page


def test_names_are_escaped(tmp_path: Path) -> None:
    hostile = 'D1 <script>alert(1)</script> & "x"'
    csv = tmp_path / "r.csv"
    rows = ["characteristic,nominal,actual,lower,upper,part,timestamp"]
    rows += [
        f'"{hostile.replace(chr(34), chr(34) * 2)}",5,{5 + 0.001 * (i % 3)},-0.01,0.01,p{i},2026-01-01T0{i}:00:00'
        for i in range(5)
    ]
    csv.write_text("\n".join(rows) + "\n", encoding="utf-8")
    db = tmp_path / "h.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=(csv,)))
        page = spc_page(spc_report(store, SpcRequest()))
    assert "<script" not in page
    assert "D1 &lt;script&gt;alert(1)&lt;/script&gt; &amp; &quot;x&quot;" in page
    tags(page)


def test_correction_page_holds_verdict_registers_rules_binding_and_predictions(loop_spc: SpcOutcome) -> None:
    outcome = correct_report(load_request(GUIDE_PINS / "model.toml"), GUIDE_PINS / "cycle_01.csv")
    page = correction_page(outcome, loop_spc)
    assert not EXTERNAL.search(page)
    tags(page)
    (pc,) = outcome.cycles
    assert f'class="verdict {pc.verdict}"' in page
    rows = pc.dimension_rows()
    zone = re.search(r'<svg[^>]*class="chart zone".*?</svg>', page, re.S)
    assert zone is not None
    assert zone.group(0).count("<path") == len(rows)  # one predicted diamond per dimension
    assert zone.group(0).count("<circle") == len(rows)  # one measured dot per dimension
    for reg in pc.register_rows():
        assert f"<td>{reg['id']}</td><td>{reg['register']}</td>" in page
    names = {d.id: d.name for d in pc.model.dimensions}
    assert "binding dimensions: " + ", ".join(names[b] for b in pc.binding) in page
    # the history charts of the dimensions the SPC outcome holds
    assert page.count('class="chart individuals"') == 3


def test_correction_page_of_one_cycle_without_history() -> None:
    outcome = correct_report(load_request(GUIDE_PINS / "model.toml"), GUIDE_PINS / "cycle_02.csv")
    page = correction_page(outcome.cycles[0])
    tags(page)
    assert 'class="chart individuals"' not in page and 'class="chart zone"' in page
