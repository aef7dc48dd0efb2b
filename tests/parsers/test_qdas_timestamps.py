"""Q-DAS K0004 dates are kept for every way a file may write the value fields (issue 21, item 12).

Each variant is the real diribet sample rewritten one way (no ``/i``, leading zeros,
a tab, ``/0``); every row must keep the date of the sample as written in the original.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import pytest

from parsers.qdas import read_aqdef
from setupfix.core.errors import ParseError

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "qdas"
SINGLE = SAMPLES / "diribet_basicDfq_singlePart_threeCharacteristics.dfq"
EXPECTED = [(f"<characteristic_code_{c}>", f"2013-01-0{d}T15:18:31") for c in (1, 2, 3) for d in (1, 2, 3)]


def stamps(path: Path) -> list[tuple[str, str]]:
    table = read_aqdef(path)
    return list(zip(table["characteristic"], table["timestamp"], strict=True))


def variant(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "variant.dfq"
    path.write_text(text, encoding="latin-1")
    return path


@pytest.mark.parametrize(
    "name",
    [
        "diribet_basicDfq_singlePart_threeCharacteristics.dfq",
        "diribet_basicDfq_threeParts_differentNumberOfCharacteristics.dfq",
        "successfactory_testmeasures.dfq",
    ],
)
def test_every_row_of_the_real_samples_has_its_date(name: str) -> None:
    table = read_aqdef(SAMPLES / name)
    assert len(table) and (table["timestamp"].str.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d$")).all()


def test_the_single_part_sample_dates_each_value() -> None:
    assert stamps(SINGLE) == EXPECTED


@pytest.mark.parametrize(
    ("how", "rewrite"),
    [
        ("no /i on the value fields", lambda t: re.sub(r"^K0004/\d+ ", "K0004 ", t, flags=re.M)),
        ("leading zeros in /i", lambda t: re.sub(r"^(K000[14])/(\d)", r"\1/00\2", t, flags=re.M)),
        ("a tab after the key", lambda t: re.sub(r"^(K0004/\d+) ", "\\1\t", t, flags=re.M)),
        ("CRLF line ends", lambda t: t.replace("\n", "\r\n")),
    ],
)
def test_rewritten_sample_keeps_every_date(tmp_path: Path, how: str, rewrite: Callable[[str], str]) -> None:
    text = SINGLE.read_text(encoding="latin-1")
    changed = rewrite(text)
    assert changed != text, how
    assert stamps(variant(tmp_path, changed)) == EXPECTED, how


HEAD = (
    "K0100 2\nK1001 P1\nK2001/1 A\nK2101/1 10\nK2110/1 9\nK2111/1 11\nK2001/2 B\nK2101/2 20\nK2110/2 19\nK2111/2 21\n"
)


def test_interleaved_values_dated_by_slash_zero_and_by_unindexed_lines(tmp_path: Path) -> None:
    text = HEAD + (
        "K0001/1 10.1\nK0001/2 20.1\nK0004/0 01.01.2013/15:18:31\n"
        "K0001/1 10.2\nK0004 02.01.2013/15:18:31\nK0001/2 20.2\nK0004 03.01.2013/15:18:31\n"
    )
    assert stamps(variant(tmp_path, text)) == [
        ("A", "2013-01-01T15:18:31"),
        ("B", "2013-01-01T15:18:31"),
        ("A", "2013-01-02T15:18:31"),
        ("B", "2013-01-03T15:18:31"),
    ]


def test_unindexed_date_after_an_uncoded_value_line_dates_the_whole_line(tmp_path: Path) -> None:
    text = HEAD + "10.1\x0f20.1\nK0004 04.01.2013/06:00:00\n10.2\x140\x1405.01.2013/07:00\x0f20.2\n"
    assert stamps(variant(tmp_path, text)) == [
        ("A", "2013-01-04T06:00:00"),
        ("B", "2013-01-04T06:00:00"),
        ("A", "2013-01-05T07:00:00"),
        ("B", ""),
    ]


@pytest.mark.parametrize("line", ["K0004/1 01.01.2013/15:18:31", "K0004/02 01.01.2013/15:18:31"])
def test_a_date_with_no_value_above_it_is_refused_with_its_line(tmp_path: Path, line: str) -> None:
    path = variant(tmp_path, HEAD + line + "\nK0001/1 10.1\n")
    with pytest.raises(ParseError, match=r"variant\.dfq:11: K0004 \(date\) before"):
        read_aqdef(path)
