"""HEIDENHAIN: one ``TOOL.T`` and one ``PRESET.PR`` table, well formed (issue 37, item 17).

Variants of the issue's case (two ``BEGIN TOOL.T`` blocks): tools of one-axis models mixing length wear and
geometry, a multi-axis tool with a radius beside one without, presets with and without a rotation.  Each table
opens once, ends once, and every cell sits in its header's column; a cell the row does not change is blank.
"""

from __future__ import annotations

import re

import pytest
from multi_axis_rows import row

from setupfix.correction.offsets import OffsetRow
from setupfix.outputs.controllers import render


def tables(text: str) -> dict[str, list[dict[str, str]]]:
    """Table name → its rows (column → cell, blank cells included), read at the header's fixed positions."""
    lines = text.rstrip("\n").split("\n")
    out: dict[str, list[dict[str, str]]] = {}
    i = 0
    while i < len(lines):
        m = re.fullmatch(r"BEGIN (\S+) (MM|INCH)", lines[i])
        assert m, f"line {i + 1} outside a table: {lines[i]!r}"
        name = m.group(1)
        assert name not in out, f"{name} opened twice"
        header = lines[i + 1]
        starts = [h.start() for h in re.finditer(r"\S+", header)]
        names = header.split()
        rows: list[dict[str, str]] = []
        i += 2
        while lines[i] != "[END]":
            line = lines[i]
            assert not line.startswith("BEGIN"), f"{name}: a table opened inside another"
            cells = [line[a:b] for a, b in zip(starts, [*starts[1:], None], strict=True)]
            for cell in cells:  # a value starts at its column (nothing spills over from the left)
                assert cell == "" or not cell[0].isspace() or not cell.strip(), (name, line)
            rows.append({n: c.strip() for n, c in zip(names, cells, strict=True)})
            i += 1
        out[name] = rows
        i += 1
    return out


CASES: list[tuple[list[OffsetRow], dict[str, dict[str, str]]]] = [
    (  # one-axis: a wear tool and a geometry tool
        [
            row("T5", "T5", "tool", "Z", -0.008, -0.012, offset="wear"),
            row("T7", "T7", "tool", "Z", 0.004, 120.5, offset="geometry"),
        ],
        {"5": {"L": "", "DL": "-0.020"}, "7": {"L": "+120.504", "DL": ""}},
    ),
    (  # multi-axis: tool 5 length and radius (wear), tool 12 length geometry only, tool 3 radius geometry only
        [
            row("T5", "T5", "tool", "Z", -0.008, -0.012, offset="wear"),
            row("T5.R", "T5", "tool", "R", 0.001, -0.003, offset="wear", number=5),
            row("T12", "T12", "tool", "Z", 0.002, 99.0),
            row("T3.R", "T3", "tool", "R", -0.002, 4.0, number=3),
        ],
        {
            "5": {"L": "", "DL": "-0.020", "R": "", "DR": "-0.002"},
            "12": {"L": "+99.002", "DL": "", "R": "", "DR": ""},
            "3": {"L": "", "DL": "", "R": "+3.998", "DR": ""},
        },
    ),
]


@pytest.mark.parametrize(("rows", "want"), CASES)
def test_one_tool_table_with_a_row_per_tool(rows: list[OffsetRow], want: dict[str, dict[str, str]]) -> None:
    text = render("heidenhain", rows, "r.csv P1")
    assert text.count("BEGIN TOOL.T") == 1 and text.count("[END]") == 1
    (found,) = tables(text).values()
    got = {r["T"]: {c: v for c, v in r.items() if c != "T"} for r in found}
    assert got == want
    assert list(got) == list(want)  # model order


def test_one_preset_table_with_a_row_per_preset() -> None:
    rows = [
        row("W1.X", "G54", "wks", "X", 0.001, 10.0, number=1),
        row("W1.C", "G54", "wks", "C", 0.01, 0.5, number=1),
        row("W2", "G55", "wks", "Z", -0.002, -400.0, number=4),
        row("T5", "T5", "tool", "Z", -0.008, -0.012, offset="wear"),
    ]
    text = render("heidenhain", rows)
    found = tables(text)
    assert list(found) == ["PRESET.PR", "TOOL.T"]
    assert found["PRESET.PR"] == [
        {"NO": "1", "X": "+10.001", "Z": "", "SPC": "+0.510"},
        {"NO": "4", "X": "", "Z": "-400.002", "SPC": ""},
    ]
    assert found["TOOL.T"] == [{"T": "5", "DL": "-0.020"}]
