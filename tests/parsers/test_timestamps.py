"""parsers.timestamps: the one timestamp parser (logs, store, report part times, the forecast's hours)."""

from __future__ import annotations

from datetime import datetime

import pytest

from parsers.timestamps import instant, iso_text, parse_timestamp, to_index
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.correction.pose import hours_between

HERE = SourceLocation("r.csv", line=3)


@pytest.mark.parametrize(
    "text", ["2026-11-02T08:00:00", "2026-11-02T09:00:00+01:00", "2026-11-02T08:00:00Z", "2026-11-02 03:00:00-05:00"]
)
def test_one_instant_however_written(text: str) -> None:
    assert instant(text, HERE) == datetime(2026, 11, 2, 8, 0, 0)


def test_a_local_time_is_kept_as_written() -> None:
    assert iso_text("2026-11-02T09:00:00+01:00", HERE) == "2026-11-02T09:00:00+01:00"
    assert list(to_index([parse_timestamp("2026-11-02T09:00:00+01:00", HERE)])) == [datetime(2026, 11, 2, 8)]


@pytest.mark.parametrize(
    ("text", "message"), [("04.11.2026 08:00", "timestamp '04.11.2026 08:00' is not ISO 8601"), ("", "empty timestamp")]
)
def test_not_iso_is_named_with_its_place(text: str, message: str) -> None:
    with pytest.raises(ParseError, match=f"r.csv:3: {message}"):
        instant(text, HERE)


def test_hours_between_compares_in_utc() -> None:
    assert hours_between("2026-11-02T10:00:00+02:00", "2026-11-02T06:00:00", "r.csv") == pytest.approx(2.0)
    assert hours_between("2026-11-03T06:00:00Z", "2026-11-02T06:00:00+00:00", "r.csv") == pytest.approx(24.0)
    with pytest.raises(ParseError, match=r"r.csv: timestamp '11/03/2026' is not ISO 8601"):
        hours_between("11/03/2026", "2026-11-02T06:00:00", "r.csv")
