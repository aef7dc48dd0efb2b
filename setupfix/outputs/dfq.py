"""The stored measurements as a Q-DAS AQDEF transfer file (``.dfq``), for the SPC tools shops run (qs-STAT).

One part description (K1001 part number, K1002 title) and one variable characteristic
per distinct (name, nominal, limits) of the canonical measurement table
(``../shared/spec/measurements.md``, lengths in mm):

* K2001 characteristic number, K2002 its name, K2004 0 (variable), K2101 nominal,
  K2110 / K2111 lower / upper limit as absolute values (nominal + allowance) and
  K2112 / K2113 the allowances themselves (a side without a limit is left out),
  K2142 unit ``mm``;
* per measured value, in time order: K0001 value, K0004 time (``dd.mm.yyyy/hh:mm:ss``;
  a time with an offset converted to UTC), K0006 the report it came from (batch),
  K0007 the fixture station when it is a whole number (nest), K0014 the part ident.

Numbers are written as plain decimals of their shortest round-trip form, so every
value and allowance reads back as the same float.  (:func:`parsers.qdas.read_aqdef`
takes a limit as K2110 − K2101 when both are given: within a rounding of the nominal,
not bit for bit, of the stored allowance.)  Reference-only rows are the caller's to
leave out.
"""

from __future__ import annotations

import math
import os
import unicodedata
from dataclasses import dataclass
from datetime import datetime
from decimal import Decimal
from typing import Any

import pandas as pd

from parsers.names import visible_name
from parsers.timestamps import parse_timestamp, utc_naive
from setupfix.core.errors import ExportError, Note, SourceLocation
from setupfix.outputs.writers import write_text
from setupfix.store import Store

__all__ = ["dfq_text", "write_dfq", "export_dfq", "DFQ_PART"]

#: K1001 part number of the exported file (the store keeps no part number of its own).
DFQ_PART = "setupfix"


def _number(value: float) -> str:
    """A float as a plain decimal that reads back as the same float (``1e-05`` → ``0.00001``)."""
    text = format(Decimal(repr(float(value))), "f")
    return "0" if text in ("-0", "0") else text


def _field(text: str, what: str, where: SourceLocation) -> str:
    """A text field for one K-field line: one line, no surrounding blanks (the reader strips them).

    Any Unicode space (category Zs: the no-break space of a spreadsheet, a thin space) is a
    blank like the ASCII one: kept as it is inside the name (it reads back the same), stripped
    around it.  A control or format character (a line or field separator, a tab, an escape, a
    zero-width or direction mark) cannot be one field and is refused, named by its code point.
    """
    bad = next((c for c in text if not (c.isprintable() or unicodedata.category(c) == "Zs")), None)
    if bad is not None:
        raise ExportError(
            f"{what} '{visible_name(text[:40])}' holds the control character U+{ord(bad):04X}: "
            "a DFQ field is one line of visible text",
            location=where,
            hint="rename it in the report, or leave the report out of the store",
        )
    return text.strip()


def _given(value: object) -> bool:
    return value is not None and not (isinstance(value, float) and math.isnan(value))


def _text(value: object) -> str:
    return str(value).strip() if _given(value) else ""


def _limit(value: object) -> float:
    return float(value) if _given(value) and str(value).strip() != "" else math.nan  # type: ignore[arg-type]


@dataclass(frozen=True)
class _Value:
    """One measured value to write, with what its characteristic is keyed by."""

    order: tuple[datetime, int]
    moment: datetime | None
    name: str
    nominal: float
    lower: float
    upper: float
    actual: float
    part: str
    report: str
    station: str

    @property
    def key(self) -> tuple[str, float, float, float]:
        """(name, nominal, lower, upper) with a missing limit as +inf (NaN would never equal itself)."""
        return (
            self.name,
            self.nominal,
            self.lower if math.isfinite(self.lower) else math.inf,
            self.upper if math.isfinite(self.upper) else math.inf,
        )


def dfq_text(
    table: pd.DataFrame, source: str = "measurements", *, title: str = "setupfix history"
) -> tuple[str, tuple[Note, ...]]:
    """The DFQ text of a canonical measurement table, and the notes (what could not be carried).

    Parameters
    ----------
    table : DataFrame
        Canonical rows (characteristic, nominal, actual or deviation, lower, upper, part,
        report, timestamp, station), lengths in mm; written in time order (rows without a
        timestamp in their given order, before the dated ones).
    source : str
        Name of the table for messages (``<store>#measurements``).

    Raises
    ------
    ExportError
        A name holding a line break or control character (it cannot be one field), or a
        row without a nominal or value.
    """
    notes: list[Note] = []
    values: list[_Value] = []
    shifted = False
    for i, r in enumerate(table.reset_index(drop=True).to_dict("records")):
        where = SourceLocation(source, line=i + 1)
        nominal = float(r["nominal"])
        raw_actual: Any = r.get("actual")
        actual = float(raw_actual) if _given(raw_actual) else nominal + float(r["deviation"])
        if not (math.isfinite(nominal) and math.isfinite(actual)):
            raise ExportError("a row without nominal or value cannot be written to DFQ", location=where)
        moment = None
        if _given(r.get("timestamp")) and str(r["timestamp"]).strip():
            stamp = parse_timestamp(str(r["timestamp"]).strip(), where)
            shifted |= stamp.tzinfo is not None
            moment = utc_naive(stamp)
        values.append(
            _Value(
                (moment or datetime.min, i),
                moment,
                _field(str(r["characteristic"]), "characteristic", where),
                nominal,
                _limit(r.get("lower")),
                _limit(r.get("upper")),
                actual,
                _field(_text(r.get("part")), "part", where),
                _field(_text(r.get("report")), "report", where),
                _text(r.get("station")),
            )
        )
    values.sort(key=lambda v: v.order)
    chars: dict[tuple[str, float, float, float], int] = {}
    for v in values:
        chars.setdefault(v.key, len(chars) + 1)
    lines = [f"K0100 {len(chars)}", f"K1001/1 {DFQ_PART}", f"K1002/1 {_field(title, 'title', SourceLocation(source))}"]
    for (name, nominal, lower, upper), k in chars.items():
        lines += [f"K2001/{k} {k}", f"K2002/{k} {name}", f"K2004/{k} 0", f"K2101/{k} {_number(nominal)}"]
        if math.isfinite(lower):
            lines += [f"K2110/{k} {_number(nominal + lower)}", f"K2112/{k} {_number(lower)}"]
        if math.isfinite(upper):
            lines += [f"K2111/{k} {_number(nominal + upper)}", f"K2113/{k} {_number(upper)}"]
        lines.append(f"K2142/{k} mm")
    odd_stations: set[str] = set()
    for v in values:
        k = chars[v.key]
        lines.append(f"K0001/{k} {_number(v.actual)}")
        if v.moment is not None:
            lines.append(f"K0004/{k} {v.moment.strftime('%d.%m.%Y/%H:%M:%S')}")
        if v.report:
            lines.append(f"K0006/{k} {v.report}")
        if v.station.isdigit():
            lines.append(f"K0007/{k} {v.station}")
        elif v.station:
            odd_stations.add(v.station)
        if v.part:
            lines.append(f"K0014/{k} {v.part}")
    if odd_stations:
        notes.append(
            Note(
                f"station(s) {', '.join(sorted(odd_stations)[:5])} are not nest numbers (K0007 holds a "
                "whole number): left out",
                SourceLocation(source),
                kind="export",
            )
        )
    if shifted:
        notes.append(
            Note(
                "times with a UTC offset are written in UTC (K0004 holds no offset)",
                SourceLocation(source),
                kind="export",
            )
        )
    return "\n".join(lines) + "\n", tuple(notes)


def write_dfq(table: pd.DataFrame, target: str | os.PathLike[str], source: str = "measurements") -> tuple[Note, ...]:
    """Write :func:`dfq_text` of ``table`` to ``target`` (atomically; ``-``: standard output); the notes."""
    text, notes = dfq_text(table, source)
    write_text(target, text)
    return notes


def export_dfq(
    store: Store, target: str | os.PathLike[str], *, include_excluded: bool = False
) -> tuple[int, tuple[Note, ...]]:
    """``history export dfq``: every stored measurement (reference-only rows left out) as a DFQ file; the
    reports marked excluded (rejected, failed, draft: :func:`setupfix.store.excluded_reports`) only with
    ``include_excluded``.

    Returns the number of values written and the notes (what the format cannot carry).

    Raises
    ------
    ExportError
        A name that cannot be one DFQ field; the target cannot be written.
    """
    table = store.measurements(include_excluded=include_excluded)
    if "reference" in table.columns:
        table = table[~table["reference"].astype(bool)]
    notes = write_dfq(table, target, f"{store.location}#measurements")
    return len(table), notes
