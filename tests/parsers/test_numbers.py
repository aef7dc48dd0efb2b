"""The one number parser (issue 9/10): the grammar a metrology file writes, nothing else."""

from __future__ import annotations

import math
from typing import Literal

import pytest
from hypothesis import given
from hypothesis import strategies as st

from parsers.numbers import parse_number, try_number
from setupfix.core.errors import ParseError, SourceLocation


@pytest.mark.parametrize(
    ("text", "decimal", "value"),
    [
        ("-0.0309", ".", -0.0309),
        ("+00020.262", ".", 20.262),
        (".1000", ".", 0.1),
        ("1.5E-3", ".", 0.0015),
        ("2.49960000000000E+0002", ".", 249.96),
        ("44,158745", ",", 44.158745),
        ("44,158745", "auto", 44.158745),
        ("  7  ", ".", 7.0),
        ("-,5", "auto", -0.5),
    ],
)
def test_reads_what_reports_write(text: str, decimal: Literal[".", ",", "auto"], value: float) -> None:
    assert parse_number(text, decimal=decimal) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize(
    "text",
    [
        "25_000.0",
        "-0_0309",
        "24_9691",
        "NaN",
        "nan",
        "inf",
        "-Infinity",
        "0x10",
        "1" * 401,
        "1,5",
        "1.2.3",
        "",
        "1e",
        "e5",
        "١٢",
        "1 000",
    ],
)
def test_refuses_what_no_metrology_file_writes(text: str) -> None:
    where = SourceLocation("r.csv", line=7)
    with pytest.raises(ParseError) as err:
        parse_number(text, location=where, what="column 'actual'")
    assert str(err.value).startswith("r.csv:7: column 'actual': ")
    assert try_number(text) is None


def test_decimal_modes_are_exclusive() -> None:
    assert try_number("1,5", decimal=".") is None
    assert try_number("1.5", decimal=",") is None
    assert try_number("1,234,5", decimal="auto") is None


def test_overflow_after_unit_conversion_is_refused() -> None:
    with pytest.raises(ParseError, match="beyond the range"):
        parse_number("1e307", scale=25.4, location=SourceLocation("r.dmo", line=3))
    assert math.isnan(parse_number(" ", allow_empty=True))


@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12))
def test_round_trips_every_printed_float(value: float) -> None:
    assert parse_number(repr(value)) == value
    assert parse_number(f"{value:.6f}") == pytest.approx(value, abs=1e-6)
