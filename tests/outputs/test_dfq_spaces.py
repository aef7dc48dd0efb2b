"""DFQ export of names holding Unicode spaces (a no-break space copied from a spreadsheet): written as they are."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from parsers.qdas import read_aqdef
from setupfix.core.errors import ExportError
from setupfix.outputs.dfq import dfq_text, write_dfq


def table(names: list[str], parts: list[str]) -> pd.DataFrame:
    n = len(names)
    return pd.DataFrame(
        {
            "characteristic": names,
            "nominal": [10.0] * n,
            "actual": [10.0 + 0.001 * i for i in range(n)],
            "deviation": [0.001 * i for i in range(n)],
            "lower": [-0.05] * n,
            "upper": [0.05] * n,
            "part": parts,
            "report": ["r\u00a01.csv"] * n,
            "timestamp": [f"2026-03-1{i}T07:00:00" for i in range(n)],
            "station": [""] * n,
        }
    )


# no-break space, narrow no-break space, thin space, ideographic space: each a blank (category Zs)
SPACES = ["\u00a0", "\u202f", "\u2009", "\u3000"]


@pytest.mark.parametrize("space", SPACES)
def test_a_unicode_space_inside_a_name_reads_back_the_same(tmp_path: Path, space: str) -> None:
    names = [f"P1{space}D1", "P1 D1", f"Bore{space}A"]  # P1 D1 with an ordinary space: another characteristic
    parts = [f"cycle{space}01", "cycle 01", "c3"]
    out = tmp_path / "spaces.dfq"
    write_dfq(table(names, parts), out)
    back = read_aqdef(out).sort_values("actual").reset_index(drop=True)
    assert list(back["characteristic"]) == names
    assert list(back["part"]) == parts
    assert out.read_text(encoding="utf-8").count("K0006/1 r\u00a01.csv\n") == 1  # the report, as stored
    assert back["characteristic"].nunique() == 3


def test_surrounding_unicode_spaces_are_blanks_like_ascii_ones() -> None:
    text, _ = dfq_text(table(["\u00a0P2 D2\u202f"], ["p"]))
    assert "K2002/1 P2 D2\n" in text


@pytest.mark.parametrize(
    ("name", "code"), [("P1\u200bD1", "U+200B"), ("P1\u2028D1", "U+2028"), ("a\x1b[31m", "U+001B")]
)
def test_an_invisible_or_line_breaking_character_is_refused_by_its_code_point(name: str, code: str) -> None:
    with pytest.raises(ExportError, match=re.escape(code)) as info:
        dfq_text(table([name], ["p"]), "store#measurements")
    assert "\x1b" not in str(info.value)  # the refusal itself shows the name escaped
    assert "store#measurements" in str(info.value)
