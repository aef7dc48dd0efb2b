"""Truncation property (issue 10) on every sample: a prefix is refused, or each of its rows is a row of the whole.

The full sweep (40 byte cuts + 40 line ends per sample) is ``bench/parse_truncation.py``
with its result in ``bench/results/parse_truncation.txt``; the suite runs a smaller,
deterministic sweep so that it stays within a few seconds.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from conftest import SHARED

import parsers
from parsers.truncation import check_prefixes, cut_points, line_cut_points
from setupfix.core.errors import ParseError, SetupfixError

ROOT = Path(__file__).resolve().parents[2]
SKIP = {".md", ".py", ".toml", ".png"}
#: Files over this size get fewer cuts (each read of a 400 KB QIF costs a tenth of a second); over
#: HUGE none here (the 2.6 MB PiWeb JSON: the bench sweeps it).
LARGE = 60_000
HUGE = 1_000_000


def _samples() -> list[Path]:
    found = sorted(p for p in (ROOT / "sample_reports").rglob("*") if p.is_file())
    found += sorted(p for p in (SHARED / "cmm-samples").rglob("*") if p.is_file())
    seen: set[bytes] = set()
    kept = []
    for p in found:
        if p.suffix.lower() in SKIP or p.name.startswith(("SOURCES", ".")) or p.stat().st_size > HUGE:
            continue
        digest = hashlib.sha1(p.read_bytes()).digest()
        if digest not in seen:  # a bundled copy of a ../shared sample is swept once
            seen.add(digest)
            kept.append(p)
    return kept


@pytest.mark.parametrize("path", _samples(), ids=lambda p: p.name)
def test_a_prefix_is_refused_or_a_subset(path: Path) -> None:
    data = path.read_bytes()
    try:
        parsers.read_report(path)
    except SetupfixError:
        pytest.skip("not readable as a whole: nothing to compare")
    n = 1 if len(data) > LARGE else 3
    outcomes = check_prefixes(str(path), data, sorted(set(cut_points(len(data), n) + line_cut_points(data, n))))
    changed = [o for o in outcomes if o.verdict == "changed"]
    assert not changed, f"{path.name}: prefix of {changed[0].cut} bytes yields {changed[0].detail}"


@pytest.mark.parametrize(
    ("name", "data", "message"),
    [
        ("r.csv", b"characteristic,nominal,actual\nP1 D4,30.0000,29.", "does not end with a line break"),
        (
            "r.dmo",
            b"UNITS/MM,ANGDEC\nF(P)=FEAT/POINT,CART,1,0,0,0,0,1\nFA(P)=FEAT/POINT,CART,1.5,0,0,0,0,1\n"
            b"TA(P_X)=TOL/CORTOL,XAXIS,0.5,OUTOL\n",
            "does not end with its ENDFIL line",
        ),
    ],
)
def test_the_issue_examples_are_refused_with_a_clear_message(name: str, data: bytes, message: str) -> None:
    with pytest.raises(ParseError, match=f"{message}: the .* file may be truncated"):
        parsers.read_report(parsers.Source(name, data))


def test_an_unterminated_last_line_without_data_is_accepted() -> None:
    whole = (ROOT / "sample_reports" / "qdas" / "successfactory_testmeasures.dfq").read_bytes()
    assert not whole.endswith(b"\n")  # the real writer leaves its last K0081 line open
    assert len(parsers.read_report(parsers.Source("t.dfq", whole)).table) > 0
