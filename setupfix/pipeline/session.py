"""Use case "operator session": what the operator's screen asks of the pipeline.

Open a report against a model — its corrections, or, when the report and the model
do not match, the match table with suggestions instead of an error — and find the
newest report in a watched folder once its writer has finished with it.
"""

from __future__ import annotations

import time
from datetime import datetime
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

import parsers
from setupfix.errors import ExportError, MatchError, ParseError, SourceLocation
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts
from setupfix.optimize import CorrectionProblem, OptimizeResult, get_optimizer
from setupfix.pipeline.compare import DEFAULT_METHODS, Comparison, MethodTrials, trial_seeds
from setupfix.pipeline.controllers import read_current, render
from setupfix.pipeline.correct import PartCorrection, correct_report, open_history
from setupfix.pipeline.cycles import assign_stations
from setupfix.pipeline.view import MatchRow, match_rows, matched_rows
from setupfix.store import CORRECTION_COLUMNS, Recommendation, open_store

__all__ = ["OpenedReport", "open_report", "newest_report", "FolderWatch", "compare_steps", "store_parts", "offsets_text",
           "record_applied"]


@dataclass(frozen=True)
class OpenedReport:
    """A report opened against a model.

    ``matches`` ties every characteristic of the report to a dimension (or lists close
    names).  ``corrections`` holds one correction per cycle; it is empty when the
    report could not be tied to the model, and ``problem`` then says why.  ``current``
    holds the controller's current offsets by register ID when they were given.
    """

    model: ProcessModel
    report: str
    format: str
    corrections: tuple[PartCorrection, ...] = ()
    matches: tuple[MatchRow, ...] = ()
    problem: str = ""
    current: Mapping[str, float] | None = None
    notes: tuple[str, ...] = ()  #: the reader's notes (rows skipped, units assumed, …) with their places

    @property
    def unmatched(self) -> int:
        """Number of report characteristics that match no dimension."""
        return sum(not m.matched for m in self.matches)


def open_report(model: ProcessModel | str | Path, report: str | Path, *, optimizer: str = "exact",
                seed: int | None = None, db: str | Path | None = None,
                current: str | Path | None = None) -> OpenedReport:
    """Read ``report`` (any supported format), tie it to ``model`` and correct every cycle
    as ``setupfix correct`` does (:func:`~setupfix.pipeline.correct.correct_report`: the
    model's effects forecast, its safety rules, smoothing from the store ``db``, the
    cumulative limit from the ``current`` offsets file).

    Raises
    ------
    SetupfixError
        When the model, the current offsets or the report cannot be read (a report
        that does not match the model is not an error: see :class:`OpenedReport`).
    """
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    path = Path(report)
    if path.is_dir():
        raise ParseError("is a folder, not a report", location=SourceLocation(str(report)))
    # Read once here for the reader's notes as data (correct_report reads the file again:
    # its own path still reports them through the warnings module, which threads cannot share).
    read = parsers.read_report(path)
    notes = tuple(str(n) for n in read.notes)
    values = read_current(current, model) if current is not None else None
    try:
        if db is not None and Path(db).is_file():  # a new store has no history to smooth over
            with open_history(db) as store:
                corrections = correct_report(model, path, optimizer=optimizer, seed=seed, store=store,
                                             current=values)
        else:
            corrections = correct_report(model, path, optimizer=optimizer, seed=seed, current=values)
    except MatchError as exc:
        return OpenedReport(model, str(report), read.format, matches=tuple(match_rows(model, read.table)),
                            problem=str(exc), current=values, notes=notes)
    return OpenedReport(model, str(report), read.format, corrections=tuple(corrections),
                        matches=tuple(matched_rows(model, [c.part for c in corrections])), current=values,
                        notes=notes)


def offsets_text(opened: OpenedReport, controller: str, *, cycle: int | None = None) -> str:
    """The offsets of every cycle in ``controller`` format, exactly as
    :func:`~setupfix.pipeline.correct.write_correction_offsets` writes them (absolute
    *set* rows when the current offsets are known).

    A controller program holds one correction: with several cycles, ``cycle`` (an
    index into ``opened.corrections``) chooses it, as ``--part`` does for ``correct``.

    Raises
    ------
    ExportError
        A rejected cycle (nothing may be written), several cycles for a controller
        program, or a register the format cannot express.
    """
    results = opened.corrections
    if controller != "csv" and len(results) > 1 and cycle is not None:
        results = (results[cycle],)
    if not results:
        raise ExportError("nothing to export: no correction", location=SourceLocation(opened.report))
    rejected = [r for r in results if r.verdict == "reject"]
    if rejected:
        raise ExportError(f"part {rejected[0].part.part or '—'} is rejected: {rejected[0].recommendation.alarm}",
                          location=SourceLocation(opened.report))
    if controller != "csv" and len(results) > 1:
        raise ExportError(f"{controller}: a program holds one correction, the report has {len(results)} cycles",
                          location=SourceLocation(opened.report), hint="choose one cycle")
    rows = [row for r in results for row in r.offsets(opened.current)]
    return render(controller, rows, f"{results[0].part.report} {results[0].part.part}".strip())


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


def compare_steps(problem: CorrectionProblem, *, methods: Sequence[str] = DEFAULT_METHODS, trials: int = 12,
                  seed: int = 0) -> Iterator[tuple[str, int, int, Comparison]]:
    """:func:`~setupfix.pipeline.compare.compare_problem` one trial at a time.

    Yields ``(method, step, steps, comparison so far)`` after the exact optimum and
    after every trial, so that a caller can show progress and stop within one trial;
    the last comparison equals ``compare_problem(problem, methods=…, trials=…, seed=…)``
    (same seeds, same order).
    """
    if trials < 1:
        raise ValueError("trials must be at least 1")
    seeds = trial_seeds(seed, trials)
    steps = 1 + len(methods) * trials
    exact = get_optimizer("exact").solve(problem)
    done: list[MethodTrials] = []
    skipped: dict[str, str] = {}
    step = 1
    yield "exact", step, steps, Comparison(problem=problem, exact=exact, methods=[], seed=seed, trials=trials)
    for name in methods:
        try:
            get_optimizer(name, seed=seeds[0])
        except ModuleNotFoundError as exc:  # a method still being written: skipped, as compare_problem does
            skipped[name] = f"not available: {exc}"
            step += trials
            yield name, step, steps, Comparison(problem, exact, list(done), seed, trials, skipped=dict(skipped))
            continue
        runs: list[OptimizeResult] = []
        for s in seeds:
            runs.append(get_optimizer(name, seed=s).solve(problem))
            step += 1
            partial = [*done, MethodTrials(name, seeds[:len(runs)], list(runs))]
            yield name, step, steps, Comparison(problem, exact, partial, seed, trials, skipped=dict(skipped))
        done.append(MethodTrials(name, seeds, runs))


def store_parts(model: ProcessModel, db: str | Path) -> tuple[list[PartMeasurement], list[str]]:
    """Every cycle stored in the history store ``db``, tied to ``model``, oldest first.

    A stored report that does not match the model is left out and named in the notes.
    """
    notes: list[str] = []
    parts: list[PartMeasurement] = []
    with open_store(db) as store:
        names = {r.sha256: r.name for r in store.reports()}
        rows = store.measurements()
    for sha, table in rows.groupby("report_sha256", sort=False):
        try:
            parts += match_parts(model, assign_stations(model, table), source=names.get(str(sha), str(sha)))
        except MatchError as exc:
            notes.append(f"left out: {exc}")
    parts.sort(key=lambda p: p.timestamp or "")
    return parts, notes


def record_applied(db: str | Path, corrections: Sequence[PartCorrection], *, when: str | None = None) -> int:
    """Record corrections as applied now: the corrections log (non-zero changes, by
    controller register name) and the recommendations, in one transaction.

    Returns
    -------
    int
        Correction rows added.
    """
    stamp = when or datetime.now().replace(microsecond=0).isoformat()
    rows = [(stamp, reg.register, float(c.corrections.get(reg.id, 0.0)), "correction")
            for c in corrections for reg in c.model.registers
            if not reg.fixed and c.corrections.get(reg.id, 0.0) != 0.0]
    with open_store(db) as store, store.transaction():
        added = store.add_corrections(pd.DataFrame(rows, columns=list(CORRECTION_COLUMNS)))
        for c in corrections:
            store.add_recommendation(Recommendation(
                optimizer=c.result.optimizer, created_at=stamp,
                inputs={"model": c.model.source, "report": c.part.report, "part": c.part.part, "applied": True},
                result=c.to_json()))
    return added
