"""Smoothing over consecutive reports (EWMA λ) from the history store, reset on a tool change.

The estimate of each dimension is an exponentially weighted mean of the current
report and the earlier parts of the same model held in the store (Siemens measuring
cycles' mean value with weighting factor k = 1/λ; Renishaw/EZ-Comp running
average).  An earlier part's deviation is first shifted by the corrections applied
since it was machined (the corrections log, through the relation matrix), so every
value describes the machine as it is now; a tool change since then drops that part's
values of the dimensions the tool cuts (its wear restarted).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from setupfix.errors import SetupfixError
from setupfix.model import PartMeasurement, ProcessModel, match_parts
from setupfix.relation import relation_matrices
from setupfix.safety import ewma_series
from setupfix.store import Store

__all__ = ["Smoothed", "smooth_part", "HISTORY"]

#: Earlier reports looked at, newest first (weights (1 − λ)^50 are negligible for λ ≥ 0.1).
HISTORY = 50


@dataclass(frozen=True)
class Smoothed:
    """The smoothed deviations of one part and how many earlier parts entered them."""

    deviation: np.ndarray
    used: int
    note: str = ""


def _stamp(text: str | None) -> pd.Timestamp | None:
    if not text:
        return None
    try:
        t = pd.Timestamp(text)
    except (ValueError, TypeError):
        return None
    return t.tz_convert("UTC").tz_localize(None) if t.tzinfo is not None else t


def smooth_part(model: ProcessModel, part: PartMeasurement, store: Store, lam: float) -> Smoothed:
    """EWMA estimate of ``part``'s deviations (model order, NaN where not measured).

    The part must carry a timestamp; earlier parts are those of the store's reports
    (matched to ``model``; reports of other processes are left out) machined before it.
    """
    now = _stamp(part.timestamp)
    if lam >= 1.0:
        return Smoothed(part.deviation, 0)
    if now is None:
        return Smoothed(part.deviation, 0, "no timestamp in the report: not smoothed")
    earlier: list[tuple[pd.Timestamp, np.ndarray]] = []
    for record in sorted(store.reports(), key=lambda r: r.imported_at, reverse=True)[:HISTORY]:
        try:
            parts = match_parts(model, store.measurements(record.sha256), source=record.name)
        except SetupfixError:
            continue
        for p in parts:
            t = _stamp(p.timestamp)
            if t is not None and t < now:
                earlier.append((t, p.deviation))
    if not earlier:
        return Smoothed(part.deviation, 0)
    earlier.sort(key=lambda e: e[0])
    earlier = earlier[-HISTORY:]
    comp = relation_matrices(model).composite  # (registers, dimensions)
    log = store.corrections()
    times = [_stamp(str(t)) for t in log["timestamp"]] if len(log) else []
    ids = model.register_ids
    rows = []
    for t, dev in earlier:
        shift = np.zeros(len(ids))
        reset = np.zeros(comp.shape[1], dtype=bool)
        for (_, entry), when in zip(log.iterrows(), times):
            if when is None or not (t < when <= now):
                continue
            try:
                reg = model.register(str(entry["register"]))
            except KeyError:
                continue
            j = ids.index(reg.id)
            if str(entry.get("event") or "correction") == "tool_change":
                reset |= comp[j] != 0
            elif pd.notna(entry["delta"]):
                shift[j] += float(entry["delta"])
        row = dev + shift @ comp
        row[reset] = np.nan
        rows.append(row)
    rows.append(part.deviation)
    smoothed = ewma_series(np.vstack(rows), lam)
    return Smoothed(np.where(np.isnan(part.deviation), np.nan, smoothed), len(earlier))
