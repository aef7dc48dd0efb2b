"""The smoothing history: earlier parts and the corrections log as arrays, from the store or given.

The EWMA estimate of a cycle (``[safety] ewma`` = λ < 1) is an exponentially weighted mean
of the cycle and the earlier parts of the same model (Siemens measuring cycles' mean value
with weighting factor k = 1/λ; Renishaw/EZ-Comp running average).  :class:`History` holds
what it needs as arrays — read once from the history store (``correct --store``) or built
from the parts of a batch — and :func:`setupfix.correction.ewma.ewma_history` computes the estimate:
each earlier part shifted by the corrections logged since (eqs. 3–4), reset on a tool change.

A part counts once however often it is stored: its identity is what was measured — part
name, time and deviations (:func:`part_identity`) — never the bytes of the file that
brought it (a CRLF copy of a report, or ``history export`` imported again, changes
nothing).  The history is deduplicated here, on read, the one place every door's history
goes through; the store keeps what it was given (reports by content hash).  Rows of one
stored table that came from several reports (an exported table, its ``report`` column)
are matched report by report (:func:`history_parts`), as they were first stored.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from parsers.timestamps import instant
from setupfix.core.errors import Note, ParseError, SetupfixError, SourceLocation
from setupfix.correction.ewma import Smoothed, ewma_history, last_measured, shifted_history
from setupfix.correction.relation import relation_matrices
from setupfix.model import PartMeasurement, ProcessModel, match_parts
from setupfix.store import Store, report_tables, stored_corrections

__all__ = ["History", "HISTORY", "history_parts", "part_identity"]

Array = npt.NDArray[np.float64]

#: Earlier parts an estimate looks at: the last ones machined before the cycle (weights (1 − λ)^50 are
#: negligible for λ ≥ 0.1).  The history itself holds every part (:meth:`History.from_store`).
HISTORY = 50


def _stamp(part: PartMeasurement) -> np.datetime64 | None:
    """When ``part`` was machined (the one parser, :func:`parsers.timestamps.instant`); None when not given.

    Raises
    ------
    ParseError
        A timestamp that is not ISO 8601 (named with the report).
    """
    if part.timestamp is None or not str(part.timestamp).strip():
        return None
    return np.datetime64(instant(part.timestamp, SourceLocation(part.report)), "ns")


#: Deviations equal to this many decimals [model unit] are the same measurement (a value written to
#: CSV and read back comes back within far less; a CMM resolves ~1e-4 mm).
IDENTITY_DECIMALS = 9


def part_identity(name: str, time: np.datetime64, deviation: Array) -> tuple[object, ...]:
    """What makes a measured part itself: (name, time [ns], deviations rounded to :data:`IDENTITY_DECIMALS`).

    Two stored copies of one part (any file bytes) have one identity; two parts of one name
    and time that measured differently (unnamed parts within the report's time resolution)
    have two.
    """
    rounded = np.round(np.asarray(deviation, dtype=float), IDENTITY_DECIMALS)
    return (
        name,
        int(np.asarray(time, dtype="datetime64[ns]").astype(np.int64)),
        tuple(None if np.isnan(v) else float(v) + 0.0 for v in rounded),
    )


def history_parts(model: ProcessModel, table: pd.DataFrame, *, source: str) -> list[PartMeasurement]:
    """The parts of one report's canonical table for the history, one report at a time.

    A table whose ``report`` column names several reports (``history export``'s measurement
    table, ``setupfix parse`` of several reports) is split by it first, so that parts of
    different reports sharing a name (unnamed parts) are not merged into one.

    Raises
    ------
    MatchError
        :func:`setupfix.model.match_parts`, of the first report that does not match.
    """
    if "report" not in table or table["report"].nunique(dropna=False) <= 1:
        return match_parts(model, table, source=source)
    parts: list[PartMeasurement] = []
    for _, rows in table.groupby(table["report"].fillna(""), sort=False):
        parts += match_parts(model, rows.reset_index(drop=True), source=source)
    return parts


@dataclass(frozen=True, eq=False)
class History:
    """What the smoothing of a cycle needs: the earlier parts and the corrections log, as arrays.

    Attributes
    ----------
    times : ndarray of datetime64[ns], shape (n_parts,)
        When each earlier part was machined.
    deviations : ndarray of shape (n_parts, n_dimensions) [unit]
        Their deviations in model order (NaN where not measured).
    keys : tuple of str
        Part names (a part already held -- same :func:`part_identity` -- is not added twice by
        :meth:`with_parts`).
    log_times, log_register, log_delta, log_reset : ndarrays of shape (n_log,)
        The corrections log: time, register index in the model (−1: not in it),
        change [unit], tool change.
    """

    times: npt.NDArray[np.datetime64]
    deviations: Array
    keys: tuple[str, ...]
    log_times: npt.NDArray[np.datetime64]
    log_register: npt.NDArray[np.int64]
    log_delta: Array
    log_reset: npt.NDArray[np.bool_]

    @classmethod
    def empty(cls, model: ProcessModel) -> History:
        t = np.array([], dtype="datetime64[ns]")
        return cls(
            t,
            np.zeros((0, len(model.dimensions))),
            (),
            t.copy(),
            np.zeros(0, dtype=np.int64),
            np.zeros(0),
            np.zeros(0, dtype=bool),
        )

    @classmethod
    def from_store(cls, model: ProcessModel, store: Store) -> History:
        """Every part the store holds matched to ``model`` (one query), and its corrections log.

        Every stored report counts, however many: the estimate itself looks at the last
        :data:`HISTORY` parts machined before the cycle, so ``batch --store`` equals
        ``history import`` + ``correct --store``.  Reports of other processes (that do
        not match the model) are left out; a part kept by two reports (same time and
        name) counts once, as the newest import gives it.  The log is read and checked
        as ``diagnose --db`` reads it (:func:`setupfix.store.stored_corrections`).

        Raises
        ------
        ParseError
            A stored part's timestamp that is not ISO 8601 (``diagnose --db`` refuses it too).
        MatchError
            A log row the model check refuses (e.g. an unknown register).
        """
        parts: list[PartMeasurement] = []
        for record, table in reversed(report_tables(store)):
            try:
                matched = history_parts(model, table, source=record.name)
            except SetupfixError:
                continue
            for p in matched:
                _stamp(p)  # an unreadable time is refused, not left out
            parts += matched
        out = cls.empty(model).with_parts(parts)
        log = stored_corrections(store, model)
        if log is None:
            return out
        return cls(
            out.times,
            out.deviations,
            out.keys,
            log.times.values.astype("datetime64[ns]"),
            log.registers.astype(np.int64),
            log.deltas.astype(float),
            np.array([e == "tool_change" for e in log.events], dtype=bool),
        )

    def with_parts(self, parts: Sequence[PartMeasurement]) -> History:
        """This history plus ``parts`` (those with a timestamp, not already held: same :func:`part_identity`)."""
        held = {part_identity(k, t, d) for k, t, d in zip(self.keys, self.times, self.deviations, strict=True)}
        times, devs, keys = list(self.times), list(self.deviations), list(self.keys)
        for p in parts:
            try:
                t = _stamp(p)
            except ParseError:  # refused when that part itself is corrected (batch: its own line)
                continue
            if t is None:
                continue
            key = part_identity(p.part, t, p.deviation)
            if key in held:
                continue
            held.add(key)
            times.append(t)
            devs.append(np.asarray(p.deviation, dtype=float))
            keys.append(p.part)
        width = self.deviations.shape[1]
        return History(
            np.array(times, dtype="datetime64[ns]"),
            np.vstack(devs) if devs else np.zeros((0, width)),
            tuple(keys),
            self.log_times,
            self.log_register,
            self.log_delta,
            self.log_reset,
        )

    def stand_in(self, model: ProcessModel, part: PartMeasurement) -> Array | None:
        """For the dimensions ``part`` lacks, their last measurement among the :data:`HISTORY` parts machined
        before it, moved by the corrections logged since (:func:`setupfix.correction.safety.shifted_history`; NaN where
        none, where a tool changed since, or where ``part`` measures it).  None when ``part`` has no time."""
        now = _stamp(part)
        if now is None or not np.isnan(part.deviation).any():
            return None
        rows = shifted_history(
            now,
            self.times,
            self.deviations,
            self.log_times,
            self.log_register,
            self.log_delta,
            self.log_reset,
            relation_matrices(model).composite,
            HISTORY,
        )
        return np.where(np.isnan(part.deviation), last_measured(rows), np.nan)

    def smooth(self, model: ProcessModel, part: PartMeasurement, lam: float) -> Smoothed:
        """The EWMA estimate of ``part`` over every held part machined before it
        (:func:`setupfix.correction.ewma.ewma_history`)."""
        now = _stamp(part)
        if lam < 1.0 and now is None:
            return Smoothed(part.deviation, 0, lam, (Note("no timestamp in the report: not smoothed", None, "ewma"),))
        return ewma_history(
            part.deviation,
            now,
            self.times,
            self.deviations,
            self.log_times,
            self.log_register,
            self.log_delta,
            self.log_reset,
            relation_matrices(model).composite,
            lam,
            limit=HISTORY,
        )
