"""Use case "operator session": what the operator's screen asks of the pipeline.

Open a report against a model — its corrections, as ``setupfix correct`` gives them
(the request :func:`~setupfix.usecases.correct.load_request` builds, one
:func:`~setupfix.usecases.correct.correct_report`), or, when the report and the model
do not match, the match table with suggestions instead of an error —, choose what an
export holds, record what was written as applied, and find the newest report in a
watched folder once its writer has finished with it.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import pandas as pd

import parsers
from parsers.names import visible_name
from setupfix.core.errors import MatchError, Note, ParseError, SourceLocation
from setupfix.inputs.cycles import assign_stations
from setupfix.inputs.stores import StoreRef
from setupfix.model import PartMeasurement, ProcessModel, match_parts
from setupfix.store import CORRECTION_COLUMNS, Recommendation, report_tables
from setupfix.usecases.compare import compare_steps  # the TUI's worker takes it from here, with store_parts
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import Exported
from setupfix.usecases.requests import CorrectOutcome, CorrectRequest, CurrentOffsets, CycleCorrection
from setupfix.views.correction import MatchRow, match_rows, matched_rows

__all__ = [
    "OpenedReport",
    "open_report",
    "export_cycles",
    "newest_report",
    "FolderWatch",
    "compare_steps",
    "store_parts",
    "record_applied",
]


@dataclass(frozen=True)
class OpenedReport:
    """A report opened against a model (``report``: its printable name, :func:`parsers.names.visible_name`).

    ``outcome`` is :func:`~setupfix.usecases.correct.correct_report`'s, for the
    ``request`` built from the operator's inputs; it is None when the report could not
    be tied to the model, and ``problem`` then says why.  ``matches`` ties every
    characteristic of the report to a dimension (or lists close names).
    """

    request: CorrectRequest
    report: str
    format: str
    outcome: CorrectOutcome | None = None
    matches: tuple[MatchRow, ...] = ()
    problem: str = ""
    notes: tuple[Note, ...] = ()  #: the reader's notes (rows skipped, units assumed, …) with their places

    @property
    def model(self) -> ProcessModel:
        return self.request.model

    @property
    def current(self) -> CurrentOffsets | None:
        """The controller's current offsets by register ID, when given."""
        return self.request.current

    @property
    def corrections(self) -> tuple[CycleCorrection, ...]:
        """One correction per cycle (none when the report does not match the model)."""
        return self.outcome.cycles if self.outcome is not None else ()

    @property
    def unmatched(self) -> int:
        """Number of report characteristics that match no dimension."""
        return sum(not m.matched for m in self.matches)


def open_report(request: CorrectRequest, report: str | Path) -> OpenedReport:
    """Read ``report`` once (any supported format) and correct every cycle with ``request``,
    exactly as ``setupfix correct`` does.

    Raises
    ------
    SetupfixError
        When the report cannot be read (a report that does not match the model is not
        an error: see :class:`OpenedReport`).
    """
    path = Path(report)
    if path.is_dir():
        raise ParseError("is a folder, not a report", location=SourceLocation(visible_name(str(report))))
    source = parsers.load_source(str(path))
    try:
        outcome = correct_report(request, source)
    except MatchError as exc:  # the match table from the same bytes: what matches, what is close
        read = parsers.read_report(source, **request.read.kwargs())
        return OpenedReport(
            request,
            source.name,
            read.format,
            matches=tuple(match_rows(request.model, read.table)),
            problem=str(exc),
            notes=tuple(read.notes),
        )
    return OpenedReport(
        request,
        source.name,
        outcome.format,
        outcome,
        matches=tuple(matched_rows(request.model, [c.part for c in outcome.cycles])),
        notes=outcome.notes,
    )


def export_cycles(opened: OpenedReport, controller: str, cycle: int | None = None) -> tuple[CycleCorrection, ...]:
    """What an export of ``opened`` holds: every cycle in an offsets CSV; in a controller
    program (one correction) the cycle ``cycle`` (an index into ``opened.corrections``)
    when the report has several, as ``--part`` chooses it for ``correct``.

    :func:`~setupfix.usecases.export.offsets_text` and
    :func:`~setupfix.usecases.export.export` apply the policy (reject refused, …).
    """
    cycles = opened.corrections
    if controller != "csv" and len(cycles) > 1 and cycle is not None:
        return (cycles[cycle],)
    return cycles


def newest_report(folder: str | Path) -> Path | None:
    """The most recently modified report candidate in ``folder`` (not recursive), under the
    one folder-walk policy (:func:`parsers.list_reports`); whether it is a report is for the
    reader to say."""
    found = _newest(parsers.list_reports(folder, recursive=False))
    return None if found is None else found.path


def _newest(listing: parsers.Listing) -> parsers.FoundFile | None:
    return max(listing.files, key=lambda f: (f.mtime_ns, f.path.name), default=None)


class FolderWatch:
    """Polls a folder and reports the newest report once its size has stopped changing.

    A CMM writes its report over a while; reading it then would see half a file.  A
    candidate is handed out when it was last modified at least ``settle`` seconds ago,
    or when two consecutive polls see the same size and modification time; each file
    (by path, size and time) only once.
    """

    def __init__(self, folder: str | Path, *, settle: float = 2.0, seen: Sequence[str | Path] = ()) -> None:
        self.folder = Path(folder)
        self.settle = settle
        self._pending: tuple[Path, int, int] | None = None
        self._done: set[tuple[str, int, int]] = set()
        self._said: set[tuple[str, str]] = set()
        #: What the last poll could not look at (an unreadable folder, a broken link …), each
        #: (path, reason) once: the screen says them.
        self.problems: tuple[tuple[str, str], ...] = ()
        for p in seen:
            stamp = self._stamp(Path(p))
            if stamp is not None:
                self._done.add((str(p), *stamp))

    @staticmethod
    def _stamp(path: Path) -> tuple[int, int] | None:
        try:
            st = path.stat()
        except OSError:
            return None
        return st.st_size, st.st_mtime_ns

    def poll(self) -> Path | None:
        """The newest finished report not handed out before, else None (new problems in :attr:`problems`)."""
        listing = parsers.list_reports(self.folder, recursive=False)
        self.problems = tuple(p for p in listing.problems if p not in self._said)
        self._said.update(self.problems)
        found = _newest(listing)
        if found is None:
            self._pending = None
            return None
        path, stamp = found.path, (found.size, found.mtime_ns)
        if (str(path), *stamp) in self._done:
            return None
        if self._pending == (path, *stamp) or time.time() - stamp[1] / 1e9 >= self.settle:
            self._done.add((str(path), *stamp))
            self._pending = None
            return path
        self._pending = (path, *stamp)
        return None


def store_parts(model: ProcessModel, db: str | Path | StoreRef) -> tuple[list[PartMeasurement], list[str]]:
    """Every cycle stored in the history store ``db``, tied to ``model``, oldest first.

    A stored report that does not match the model is left out and named in the notes.
    """
    notes: list[str] = []
    parts: list[PartMeasurement] = []
    with StoreRef.of(db).for_model(model).open(existing=False) as store:
        tables = report_tables(store)
    for record, table in tables:
        try:
            parts += match_parts(model, assign_stations(model, table), source=record.name)
        except MatchError as exc:
            notes.append(f"left out: {exc}")
    parts.sort(key=lambda p: p.timestamp or "")
    return parts, notes


def record_applied(
    db: str | Path | StoreRef, exported: Exported, cycles: Sequence[CycleCorrection], *, when: str | None = None
) -> int:
    """Record what ``exported`` wrote as applied now, in one transaction: its non-zero rows
    in the corrections log (by controller register name) and, for each exported cycle
    (``exported.parts``; the others of ``cycles`` are left out), its recommendation.

    Returns
    -------
    int
        Correction rows added.
    """
    stamp = when or datetime.now().replace(microsecond=0).isoformat()
    rows = [(stamp, row.register, float(row.delta), "correction") for row in exported.rows if row.delta != 0.0]
    written = [c for c in cycles if c.part.part in exported.parts]
    model = cycles[0].model if cycles else None
    ref = StoreRef.of(db) if model is None else StoreRef.of(db).for_model(model)
    with ref.open(existing=False) as store, store.transaction():
        added = store.add_corrections(pd.DataFrame(rows, columns=list(CORRECTION_COLUMNS)))
        for c in written:
            store.add_recommendation(
                Recommendation(
                    optimizer=c.result.optimizer,
                    created_at=stamp,
                    inputs={
                        "model": c.model.source,
                        "report": c.part.report,
                        "part": c.part.part,
                        "applied": True,
                        "export": {
                            "target": visible_name(exported.target),
                            "controller": exported.controller,
                            "sha256": exported.sha256,
                        },
                    },
                    result=cycle_json(c),
                )
            )
    return added
