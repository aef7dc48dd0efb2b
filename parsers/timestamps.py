"""The one timestamp parser of the series logs (corrections log, temperature log) and the store.

``measurements.md``: timestamps are ISO 8601.  :func:`parse_timestamp` reads one (an
Excel date cell too) or names the place; :func:`iso_text` gives the normal form the
history store keeps (sortable as text); :func:`utc_naive` the instant every series
computation compares (a time with an offset converted to UTC, a local time as written).
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

import pandas as pd

from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["parse_timestamp", "iso_text", "utc_naive", "instant", "to_index", "TIMESTAMP_HINT"]

#: What the error for a bad timestamp suggests.
TIMESTAMP_HINT = "write e.g. 2026-01-05T06:00:10"


def parse_timestamp(value: Any, where: SourceLocation) -> datetime:
    """One ISO 8601 timestamp (``Z`` for UTC allowed), or a :class:`datetime` as given.

    Raises
    ------
    ParseError
        At ``where``: ``timestamp '…' is not ISO 8601`` (an empty cell: ``empty timestamp``).
    """
    if isinstance(value, datetime):
        return value
    text = "" if value is None else str(value).strip()
    if not text:
        raise ParseError("empty timestamp", location=where, hint=TIMESTAMP_HINT)
    try:
        return datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise ParseError(f"timestamp {text[:40]!r} is not ISO 8601", location=where, hint=TIMESTAMP_HINT) from None


def iso_text(value: Any, where: SourceLocation) -> str:
    """The timestamp in ISO normal form (``2026-01-05T06:00:10``, offset kept when written)."""
    return parse_timestamp(value, where).isoformat()


def utc_naive(moment: datetime) -> datetime:
    """``moment`` as a naive time: converted to UTC when it carries an offset, else as written."""
    if moment.tzinfo is None:
        return moment
    return moment.astimezone(UTC).replace(tzinfo=None)


def instant(value: Any, where: SourceLocation) -> datetime:
    """One timestamp read by :func:`parse_timestamp` as the naive instant series compare (:func:`utc_naive`).

    Raises
    ------
    ParseError
        As :func:`parse_timestamp`.
    """
    return utc_naive(parse_timestamp(value, where))


def to_index(moments: Sequence[datetime]) -> pd.DatetimeIndex:
    """Naive times (:func:`utc_naive`) as a pandas index, in the given order."""
    return pd.DatetimeIndex([utc_naive(m) for m in moments])
