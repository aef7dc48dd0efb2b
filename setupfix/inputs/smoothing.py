"""The smoothing history: earlier parts and the corrections log as arrays, from the store or given.

The EWMA estimate of a cycle (``[safety] ewma`` = λ < 1) is an exponentially weighted mean
of the cycle and the earlier parts of the same model (Siemens measuring cycles' mean value
with weighting factor k = 1/λ; Renishaw/EZ-Comp running average).  :class:`History` holds
what it needs as arrays — read once from the history store (``correct --store``) or built
from the parts of a batch — and :func:`setupfix.correction.ewma.ewma_history` computes the estimate:
each earlier part shifted by the corrections logged since (eqs. 3–4), reset on a tool change.

A part counts once however often it is stored: its identity is what was measured -- the
content identity of :mod:`setupfix.inputs.duplicates`: part name up to case and spacing,
time, and every shared deviation equal to the reports' resolution with at most one row
missing -- never the bytes of the file that brought it (a CRLF copy of a report, its
``.dmo`` beside its ``.csv``, or ``history export`` imported again, changes nothing).  The
history is deduplicated here, on read, the one place every door's history goes through; the
store keeps what it was given (reports by content hash).  Rows of one stored table that came
from several reports (an exported table, its ``report`` column) are matched report by
report (:func:`history_parts`), as they were first stored.

Reports the store keeps marked (rejected, failed, draft: :data:`setupfix.store.EXCLUDED_REASONS`)
are left out unless asked (``include_excluded``); :attr:`History.excluded` counts them and
the smoothing's notes say so.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from parsers.timestamps import instant
from setupfix.core.errors import Note, ParseError, SetupfixError, SourceLocation
from setupfix.correction.ewma import Smoothed, ewma_history, last_measured, shifted_history
from setupfix.correction.relation import relation_matrices
from setupfix.inputs.duplicates import Content, ContentIndex, content_of
from setupfix.model import PartMeasurement, ProcessModel, match_parts
from setupfix.store import ReportRecord, Store, excluded_reports, report_tables, stored_corrections

__all__ = ["History", "HISTORY", "history_parts", "stored_parts", "excluded_note"]

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


def stored_parts(
    model: ProcessModel, store: Store, *, include_excluded: bool = False
) -> list[tuple[ReportRecord, list[PartMeasurement]]]:
    """Every stored report's parts matched to ``model``, newest import first (one query).

    Reports of other processes (that do not match the model) are left out, and so are
    marked ones unless ``include_excluded``.

    Raises
    ------
    ParseError
        A stored part's timestamp that is not ISO 8601 (``diagnose --db`` refuses it too).
    """
    out: list[tuple[ReportRecord, list[PartMeasurement]]] = []
    for record, table in reversed(report_tables(store, include_excluded=include_excluded)):
        try:
            matched = history_parts(model, table, source=record.name)
        except SetupfixError:
            continue
        for p in matched:
            _stamp(p)  # an unreadable time is refused, not left out
        out.append((record, matched))
    return out


def excluded_note(count: int, what: str, *, option: bool = True) -> Note:
    """The note of a history that left ``count`` marked reports out (``what``: the history's use; ``option``:
    the command has ``--include-excluded``)."""
    return Note(
        f"{count} stored report(s) marked rejected, failed or draft left out of {what}"
        + (" (--include-excluded takes them in)" if option else ""),
        None,
        "excluded",
    )


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
        Part names (a part already held -- the same measurement,
        :func:`setupfix.inputs.duplicates.same_measurement` -- is not added twice by :meth:`with_parts`).
    log_times, log_register, log_delta, log_reset : ndarrays of shape (n_log,)
        The corrections log: time, register index in the model (−1: not in it),
        change [unit], tool change.
    excluded : int
        Marked reports of the store left out (:meth:`from_store`); the smoothing's notes say so.
    """

    times: npt.NDArray[np.datetime64]
    deviations: Array
    keys: tuple[str, ...]
    log_times: npt.NDArray[np.datetime64]
    log_register: npt.NDArray[np.int64]
    log_delta: Array
    log_reset: npt.NDArray[np.bool_]
    excluded: int = 0

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
    def from_store(
        cls,
        model: ProcessModel,
        store: Store,
        *,
        include_excluded: bool = False,
        stored: list[tuple[ReportRecord, list[PartMeasurement]]] | None = None,
    ) -> History:
        """Every part the store holds matched to ``model`` (one query), and its corrections log.

        Every stored report counts, however many: the estimate itself looks at the last
        :data:`HISTORY` parts machined before the cycle, so ``batch --store`` equals
        ``history import`` + ``correct --store``.  Reports of other processes (that do
        not match the model) are left out, and so are marked ones (rejected, failed,
        draft) unless ``include_excluded`` (:attr:`excluded` counts them); a part kept by
        two reports (the same measurement) counts once, as the newest import gives it.
        ``stored``: :func:`stored_parts` of this store already read.  The log is read and
        checked as ``diagnose --db`` reads it (:func:`setupfix.store.stored_corrections`).

        Raises
        ------
        ParseError
            A stored part's timestamp that is not ISO 8601 (``diagnose --db`` refuses it too).
        MatchError
            A log row the model check refuses (e.g. an unknown register).
        """
        if stored is None:
            stored = stored_parts(model, store, include_excluded=include_excluded)
        out = cls.empty(model).with_parts([p for _, parts in stored for p in parts])
        excluded = 0 if include_excluded else len(excluded_reports(store))
        log = stored_corrections(store, model)
        if log is None:
            return dataclasses.replace(out, excluded=excluded)
        return cls(
            out.times,
            out.deviations,
            out.keys,
            log.times.values.astype("datetime64[ns]"),
            log.registers.astype(np.int64),
            log.deltas.astype(float),
            np.array([e == "tool_change" for e in log.events], dtype=bool),
            excluded,
        )

    def _index(self, model_keys: Sequence[str]) -> ContentIndex:
        """The held parts by content."""
        index = ContentIndex()
        for k, t, d in zip(self.keys, self.times, self.deviations, strict=True):
            index.add(_content(k, t, d, model_keys))
        return index

    def with_parts(self, parts: Sequence[PartMeasurement]) -> History:
        """This history plus ``parts`` (those with a timestamp, not already held: the same measurement,
        :func:`setupfix.inputs.duplicates.same_measurement`)."""
        model_keys = [str(q) for q in range(self.deviations.shape[1])]
        held = self._index(model_keys)
        times, devs, keys = list(self.times), list(self.deviations), list(self.keys)
        for p in parts:
            try:
                t = _stamp(p)
            except ParseError:  # refused when that part itself is corrected (batch: its own line)
                continue
            if t is None:
                continue
            c = _content(p.part, t, p.deviation, model_keys)
            if held.find(c) is not None:
                continue
            held.add(c)
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
            self.excluded,
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
        said = (excluded_note(self.excluded, "the smoothing history", option=False),) if self.excluded else ()
        if lam < 1.0 and now is None:
            note = Note("no timestamp in the report: not smoothed", None, "ewma")
            return Smoothed(part.deviation, 0, lam, (note, *said))
        smoothed = ewma_history(
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
        return dataclasses.replace(smoothed, notes=(*smoothed.notes, *said)) if said else smoothed


def _content(name: str, time: np.datetime64, deviation: Array, keys: Sequence[str]) -> Content:
    """A held part's content (its time already read)."""
    ns = int(np.asarray(time, dtype="datetime64[ns]").astype(np.int64))
    return content_of(name, ns, dict(zip(keys, np.asarray(deviation, dtype=float).tolist(), strict=True)))
