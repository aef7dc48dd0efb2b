"""A report's own verdict (PASS/FAIL, OK/NG, INTOL/OUTTOL) cross-checked against its numbers (issue 14).

A verdict that contradicts ``lower <= deviation <= upper`` means the report, or our
reading of it, is wrong somewhere (the NIST FAIR box QIF says PASS for a diameter
4.4 mm off on ±0.254).  It is not refused — the numbers are what setupfix uses — but
each such row is named in one note, so the operator can look before the correction
goes into the machine.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from parsers.canonical import DEVIATION_TOLERANCE_MM
from setupfix.core.errors import Note, SourceLocation

__all__ = ["verdict_notes", "PASS_WORDS", "FAIL_WORDS"]

#: Verdict spellings (upper case) meaning "in tolerance" / "out of tolerance".
PASS_WORDS = frozenset({"PASS", "OK", "INTOL", "IN", "GOOD", "I.O.", "IO"})
FAIL_WORDS = frozenset({"FAIL", "NG", "OUT", "OUTTOL", "OUTOL", "NOK", "N.I.O.", "NIO", "BAD", "REJECT"})


def _location(source: str, path: str) -> SourceLocation:
    head, sep, tail = source.rpartition(":")
    if sep and tail.isdigit():
        return SourceLocation(head, line=int(tail))
    head, sep, tail = source.rpartition("#")
    if sep:
        return SourceLocation(head, element=tail)
    return SourceLocation(path)


def _word(value: object) -> str:
    """A status cell as the verdict word it may be: stripped, upper case ("" when missing)."""
    if value is None or (isinstance(value, float) and value != value) or value is pd.NA:
        return ""
    return str(value).strip().upper()


def _floats(column: pd.Series) -> np.ndarray:
    """A numeric column as floats (non-numbers NaN)."""
    if column.dtype == np.float64:
        return column.to_numpy()
    return pd.to_numeric(column, errors="coerce").to_numpy(float)


def verdict_notes(table: pd.DataFrame, path: str, limit: int = 8) -> list[Note]:
    """One note naming the rows whose stated verdict contradicts their deviation and limits.

    A row counts when its status is a known verdict word and both limits are given;
    the deviation may overshoot a limit by :data:`DEVIATION_TOLERANCE_MM` (rounding)
    either way before the verdict is called contradictory.

    Returns
    -------
    list of Note
        Empty, or one note (kind ``"verdict"``) located at the first such row.
    """
    if table.empty or "status" not in table:
        return []
    # Plain lists and arrays: this runs on every report read, and pandas' string methods
    # cost ~1 ms on a 28-row table; a table with no verdict word returns at once.
    status = table["status"].tolist()
    try:  # a report repeats a few spellings: each distinct cell is looked at once
        spelled = {v: _word(v) for v in set(status)}
    except TypeError:  # an unhashable cell
        spelled = None
    if spelled is not None and not any(w in PASS_WORDS or w in FAIL_WORDS for w in spelled.values()):
        return []
    word = [spelled[v] for v in status] if spelled is not None else [_word(v) for v in status]
    says_pass = np.fromiter((w in PASS_WORDS for w in word), bool, len(word))
    says_fail = np.fromiter((w in FAIL_WORDS for w in word), bool, len(word))
    if not (says_pass.any() or says_fail.any()):
        return []
    dev, lo, up = (_floats(table[c]) for c in ("deviation", "lower", "upper"))
    judged = ~np.isnan(dev) & ~np.isnan(lo) & ~np.isnan(up)
    with np.errstate(invalid="ignore"):
        clearly_out = (dev < lo - DEVIATION_TOLERANCE_MM) | (dev > up + DEVIATION_TOLERANCE_MM)
        clearly_in = (dev > lo + DEVIATION_TOLERANCE_MM) & (dev < up - DEVIATION_TOLERANCE_MM)
    bad = np.flatnonzero(judged & ((says_pass & clearly_out) | (says_fail & clearly_in)))
    if not bad.size:
        return []
    shown = []
    for i in bad[:limit]:
        row = table.iloc[int(i)]
        shown.append(
            f"{row['characteristic']} says {row['status']} at deviation {dev[i]:+.4g} mm "
            f"on [{lo[i]:+.4g}, {up[i]:+.4g}]"
        )
    more = f" (and {bad.size - limit} more)" if bad.size > limit else ""
    first = str(table["source"].iloc[int(bad[0])]) if "source" in table else ""
    return [
        Note(
            f"{bad.size} row(s) whose own verdict contradicts their numbers: " + "; ".join(shown) + more,
            _location(first, path),
            "verdict",
        )
    ]
