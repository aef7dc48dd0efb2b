"""The canonical reader's column-wise fast path against its row loop (issue 15).

``read_canonical`` reads a plain file column by column and leaves everything else
(quotes, odd line ends, any cell the loop would refuse) to the row loop.  Both must
give the same table — values, dtypes, column order — or the same refusal, on every
bundled canonical sample and on seeded random files built from good and damaged cells.
"""

from __future__ import annotations

import random
from pathlib import Path

import pandas as pd
import pytest

import parsers
import parsers.canonical as canonical
from parsers import Source
from setupfix.core.errors import SetupfixError
from setupfix.model.measurements import LENGTH_COLUMNS

ROOT = Path(__file__).resolve().parents[2]

HEADERS = (
    "actual",
    "deviation",
    "lower",
    "upper",
    "unit",
    "part",
    "station",
    "status",
    "timestamp",
    "reference",
    "report",
    "x",
    "y",
    "z",
    "source",
    "extra",
)
#: Cells a length may hold: good ones (escaped by our CSV writer, padded, exponents) and damage.
NUMBERS = (
    "",
    " 25.1 ",
    "'-0.1",
    "1.5E-3",
    ".5",
    "5.",
    "+00020.262",
    "-0",
    "1e6",
    "1e7",
    "1e8",
    "-0_0309",
    "NaN",
    "inf",
    "0x10",
    "1e400",
    "1e307",
    "1" * 41,
    "44,15",
    "abc",
    "'=1",
)
TEXTS = ("'=SUM(A1)", "'@x", " padded ", "a\u3000b", "\u3000", "x\x1by", "P1\tD1", "'", "é", "")
UNITS = ("mm", "inch", "MM", " Inch", "", "mm", "inch", "µm")
FLAGS = ("true", "0", "", "YES", " no ", "false", "1", "maybe")


def _cell(rng: random.Random, column: str, i: int, nominal: float, actual: float) -> str:
    if rng.random() < 0.03:
        return rng.choice(NUMBERS if column in LENGTH_COLUMNS else TEXTS)
    return {
        "characteristic": f"P1 D{i}",
        "nominal": f"{nominal}",
        "actual": f"{actual}",
        "deviation": f"{actual - nominal:.4f}",
        "lower": "-0.1",
        "upper": "0.1",
        "unit": rng.choice(UNITS),
        "part": rng.choice(("p", "", "q")),
        "station": "P1",
        "status": rng.choice(("", "OK", "NG")),
        "timestamp": "",
        "reference": rng.choice(FLAGS),
        "report": rng.choice(("", "r.csv")),
        "x": "1",
        "y": "",
        "z": "-2.5",
        "source": "s:1",
        "extra": "e",
    }[column]


def random_report(seed: int) -> bytes:
    """A canonical CSV of a few rows with random columns, line ends, blank lines and damaged cells."""
    rng = random.Random(seed)
    header = ["characteristic", "nominal", *rng.sample(HEADERS, rng.randint(1, 8))]
    if "actual" not in header and "deviation" not in header:
        header.append("actual")
    rng.shuffle(header)
    if rng.random() < 0.05:
        header.append(rng.choice(header))  # a repeated column
    lines = [",".join(header)]
    for i in range(rng.randint(0, 8)):
        nominal = round(rng.uniform(-100, 100), 4)
        actual = round(nominal + rng.uniform(-0.05, 0.05), 4)
        cells = [_cell(rng, h, i, nominal, actual) for h in header]
        if rng.random() < 0.05:
            cells = cells[: rng.randrange(1, len(cells))]  # a short row
        if rng.random() < 0.03:
            cells.append("x")  # a long row
        if rng.random() < 0.05:
            cells[0] = f'"{cells[0]}"'
        lines.append(",".join(cells))
        if rng.random() < 0.1:
            lines.append(rng.choice(("", " , ,", "\u3000", ",,,", "  ")))
    end = rng.choice(("\n", "\r\n", "\r\n", "\r"))
    return (end.join(lines) + (end if rng.random() < 0.95 else "")).encode("utf-8")


def _read(data: bytes, name: str, fast: bool, monkeypatch: pytest.MonkeyPatch) -> pd.DataFrame | str:
    monkeypatch.setattr(canonical, "FAST_PATH", fast)
    try:
        return parsers.read_report(Source(name, data), format="canonical").table
    except SetupfixError as exc:
        return f"{type(exc).__name__}: {exc}"


def _same(data: bytes, name: str, monkeypatch: pytest.MonkeyPatch) -> bool:
    """Assert both paths agree; True when the file was read (not refused)."""
    fast, loop = _read(data, name, True, monkeypatch), _read(data, name, False, monkeypatch)
    if isinstance(loop, str) or isinstance(fast, str):
        assert fast == loop
        return False
    pd.testing.assert_frame_equal(fast, loop, check_exact=True)
    assert list(fast.dtypes) == list(loop.dtypes)
    return True


@pytest.mark.slow
def test_random_files_read_alike_by_both_paths(monkeypatch: pytest.MonkeyPatch) -> None:
    taken: list[bool] = []  # per file read with the fast path on: whether it read the file (columns, not rows)
    real = canonical.finish_table

    def spy(rows: list[dict[str, object]] | dict[str, object], path: str) -> pd.DataFrame:
        if canonical.FAST_PATH:
            taken.append(isinstance(rows, dict))
        return real(rows, path)

    monkeypatch.setattr(canonical, "finish_table", spy)
    read = sum(_same(random_report(seed), f"r{seed}.csv", monkeypatch) for seed in range(400))
    # Both outcomes are exercised: many files read, many refused, the fast path often taken and often not.
    assert 100 < read < 350  # 135 of 400 with these seeds
    assert 50 < sum(taken) < len(taken) - 30  # the fast path built 87 of the 152 tables (fast path on)


CANONICAL_SAMPLES = [
    p
    for p in sorted((ROOT / "sample_reports").rglob("*.csv"))
    if canonical.sniff_canonical(p.read_bytes()[:4096].decode("utf-8", "replace"))
]


@pytest.mark.parametrize("path", CANONICAL_SAMPLES, ids=lambda p: p.name)
def test_bundled_canonical_reports_read_alike(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert _same(path.read_bytes(), str(path), monkeypatch)


@pytest.mark.parametrize(
    "cell, message",
    [
        ("-0_0309", "expected a number, found '-0_0309'"),
        ("NaN", "expected a number, found 'NaN'"),
        ("0x10", "expected a number, found '0x10'"),
        ("1e400", "expected a number, found '1e400'"),
        ("1e8", "beyond any measurable length"),
        ("1" * 401, "expected a number"),
    ],
)
def test_damaged_numbers_are_refused_at_their_line_by_both_paths(
    cell: str, message: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = (ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv").read_text().splitlines(keepends=True)
    cells = text[5].split(",")
    cells[2], cells[3] = cell, ""  # the actual of P1 D5 (line 6), its stated deviation left out
    text[5] = ",".join(cells)
    for fast in (True, False):
        result = _read("".join(text).encode(), "c.csv", fast, monkeypatch)
        assert isinstance(result, str) and message in result and "c.csv:6" in result


@pytest.mark.parametrize(
    "column, cell, message",
    [
        (4, "0.1", "lower limit 0.1 is not below upper limit 0.1"),
        (3, "0.02", "deviation 0.02 mm contradicts"),
        (6, "µm", "unknown unit 'µm'"),
        (0, "", "empty characteristic name"),
        (1, "", "empty nominal value"),
    ],
)
def test_row_checks_refuse_at_their_line_by_both_paths(
    column: int, cell: str, message: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = (ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv").read_text().splitlines(keepends=True)
    cells = text[5].split(",")
    cells[column] = cell
    text[5] = ",".join(cells)
    for fast in (True, False):
        result = _read("".join(text).encode(), "c.csv", fast, monkeypatch)
        assert isinstance(result, str) and message in result and "c.csv:6" in result
