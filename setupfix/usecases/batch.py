"""Use case "batch": every report in a folder tree corrected into one offsets file.

Design for thousands of reports:

* one :class:`~setupfix.usecases.requests.CorrectRequest` — the very request
  ``setupfix correct`` builds (model, reader and cycle options, optimiser, current
  offsets, thermal inputs, smoothing history) — goes to each worker process once,
  and every report runs :func:`setupfix.usecases.correct.correct_report` on it; its
  rows are :func:`setupfix.usecases.export.cycle_rows` (the export policy);
* with a history store and EWMA (λ < 1) every report is read first: the history is
  the store plus every report of the batch, so that a report is smoothed over every
  part machined before it, as ``history import`` of the same reports followed by
  ``correct --store`` on each would smooth it;
* results are streamed: each report's offset rows are written to the (atomic)
  output as soon as it is done, in the sorted order of the files, so memory does
  not grow with the number of reports and the numbers do not depend on
  ``workers``;
* a file that fails is named with its reason and skipped; the others go on (a file
  removed between the listing and its reading too); every path the summary holds is
  printable (:func:`parsers.names.visible_name`);
* a file whose size or modification time changes between discovery and reading
  (still being copied by the CMM) is not read;
* the same content twice (SHA-256) is corrected once, and so is the same measurement
  in other bytes (the ``.csv``, ``.dmo`` and ``.qif`` of one cycle, a CRLF copy, a part
  name in other case): a report whose every part repeats a part corrected earlier in
  the run -- or, with a history store, a part it holds from another report -- is skipped
  naming it, a repeated part of a report with new ones is dropped from its rows with a
  note (:mod:`setupfix.inputs.duplicates`, the one content identity); with a history
  store, reports it already holds are skipped unless ``force``;
* with a history store each report is claimed in the store before a worker gets it
  (:meth:`~setupfix.store.Store.claim_reports`, one short transaction per chunk), so
  two runs at once over one store correct each report once between them; the claims
  become "processed" only after the output is written, and are freed on any failure
  (a killed run's claims are taken over: its process is gone);
* worker processes end with the batch: each watches the batch's process (pid and
  start mark) and exits when it is gone, so a SIGKILL of the batch leaves no worker
  running.  (A thread polling the parent was chosen over ``PR_SET_PDEATHSIG``, which
  fires when the *thread* that started the worker ends and is Linux-only, and over a
  pipe's end of file, which every forked worker would hold open for its siblings.)

Nothing here prints: progress goes to a callback, the summary is returned.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import parsers
from parsers.names import visible_name
from setupfix.core.atomic import process_alive, process_started
from setupfix.core.errors import Note, ParameterError, ParseError, SetupfixError, SourceLocation
from setupfix.correction.offsets import offset_rows
from setupfix.correction.pose import pose_problem
from setupfix.correction.recommend import beyond_band, stopped_where
from setupfix.correction.safety import reject_mask
from setupfix.inputs.duplicates import Content, ContentIndex, part_content
from setupfix.inputs.smoothing import excluded_note, history_parts, stored_parts
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.outputs.batch_output import CsvOut, ProgramsOut
from setupfix.outputs.controllers import render
from setupfix.store import ALREADY_PROCESSED, HELD_ELSEWHERE, ReportRecord, Store
from setupfix.usecases.batch_records import BatchSummary, Claims, Item, Outcome, Tally, account
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import cycle_rows, offsets_text
from setupfix.usecases.requests import CorrectRequest, History

__all__ = ["find_reports", "run_batch", "batch_history", "rejected", "auto_workers", "chunk_size"]


@dataclass(frozen=True)
class _Work:
    """What every worker gets once: the request and the batch's own switches (picklable)."""

    request: CorrectRequest
    record: bool = False  #: return the bytes and table read with each outcome (for the history store)
    #: other than csv: each cycle's program text (:func:`~setupfix.usecases.export.offsets_text`)
    controller: str = "csv"


def find_reports(root: str | Path) -> parsers.Listing:
    """The reports below ``root`` under the one folder-walk policy (:func:`parsers.list_reports`).

    Raises
    ------
    ParameterError
        If ``root`` is not a folder.
    """
    if not Path(root).is_dir():
        raise ParameterError(f"batch: {root} is not a folder")
    return parsers.list_reports(root)


# -- per-report work (runs in a worker process, or inline with one worker) --------------------

_WORK: _Work | None = None

#: A report's outcome and what each of its corrected parts measured, in the order of ``Outcome.parts``.
Done = tuple[Outcome, tuple[Content, ...]]


#: Seconds between a worker's looks at whether the batch's process still runs.
WATCH_S = 0.5


def _init(work: _Work) -> None:
    global _WORK
    _WORK = work


def _init_worker(work: _Work, parent: int, started: str) -> None:
    """A worker process's start: the request, and a watch that ends the worker when the batch is gone."""
    _init(work)

    def watch() -> None:
        while process_alive(parent, started):
            time.sleep(WATCH_S)
        os._exit(1)  # the batch is gone (killed): nobody would read this worker's results

    threading.Thread(target=watch, name="setupfix-batch-watch", daemon=True).start()


def _correct_one(path: str, size: int, mtime_ns: int, claimed: str = "", refused: str = "") -> Done:
    """One report corrected, with what each of its parts measured (:func:`~setupfix.inputs.duplicates.part_content`)."""
    assert _WORK is not None
    contents: list[Content] = []
    out = Outcome(path, sha256=claimed)
    shown = visible_name(path)
    if refused:
        out.skipped = refused
        return out, tuple(contents)
    try:
        try:
            st = os.stat(path)
        except FileNotFoundError:
            out.error = f"{shown}: renamed or removed after the folder was listed: not read"
            return out, tuple(contents)
        if (st.st_size, st.st_mtime_ns) != (size, mtime_ns):
            out.skipped = "still being written (size or time changed): not read"
            return out, tuple(contents)
        source = parsers.load_source(path)  # read once: the bytes hashed are the bytes corrected
        out.sha256 = hashlib.sha256(source.data).hexdigest()
        if claimed and out.sha256 != claimed:
            out.skipped = "still being written (content changed since it was claimed): not read"
            return out, tuple(contents)
        if _WORK.record and not claimed:  # unreadable when the batch claimed it: not corrected unclaimed
            out.error = f"{path}: could not be read when it was claimed in the history store; run again"
            return out, tuple(contents)
        request = _WORK.request
        corrected = correct_report(request, source)
        if _WORK.record:  # the store records these very bytes and table: the parent reads nothing again
            out.data, out.table, out.format = source.data, corrected.table, corrected.format
        for cycle in corrected.cycles:
            out.rows += cycle_rows(cycle, request.current)
            out.verdicts.append(cycle.verdict)
            out.solved.append(cycle.solved)
            out.notes += cycle.notes
            if cycle.recommendation.alarm:  # reject, or a setup error held
                out.notes.append(Note(cycle.recommendation.alarm, SourceLocation(shown), "safety"))
            elif not cycle.solved:
                out.notes.append(Note(cycle.result.message, SourceLocation(shown), "solver"))
            elif _WORK.controller != "csv":
                out.programs.append((cycle.part.part, offsets_text([cycle], _WORK.controller, request.current)))
            where = stopped_where(cycle.result)
            if cycle.solved and where:  # a correction from a stopped solve says so, as correct does
                said = [r.message for r in cycle.recommendation.rules if r.rule == "stopped"]
                out.notes.append(Note(said[0] if said else f"stopped: {where}", SourceLocation(shown), "solver"))
            out.parts.append(cycle.part.part)
            contents.append(_content(cycle.part, request))
    except SetupfixError as exc:
        out.error = str(exc) if exc.location else f"{shown}: {exc}"
    except OSError as exc:
        out.error = f"{shown}: cannot read: {exc.strerror or exc}"
    except Exception as exc:  # noqa: BLE001 - one bad file never stops the batch
        out.error = f"{shown}: internal error: {type(exc).__name__}: {exc}"
    return out, tuple(contents)


def _content(part: PartMeasurement, request: CorrectRequest) -> Content:
    """What ``part`` measured (a timestamp the correction did not need and cannot be read: no time)."""
    return part_content(part, [d.id for d in request.model.dimensions], unreadable_time=True)


def _correct_chunk(items: list[Item]) -> list[Done]:
    return [_correct_one(*item) for item in items]


#: Most reports sent to a worker in one task.  A task per report costs a round trip
#: (pickling the arguments and the outcome, waking the parent) of ~0.5 ms, a few
#: percent of a report; chunks make that negligible while keeping progress lively.
CHUNK = 16


def chunk_size(n_files: int, workers: int) -> int:
    """Reports per task: about 8 tasks per worker, between 1 and :data:`CHUNK` reports each."""
    return max(1, min(CHUNK, -(-n_files // (8 * workers))))


def _outcomes(
    files: list[tuple[Path, int, int]],
    work: _Work,
    workers: int,
    claim: Callable[[list[Item]], list[Item]] | None = None,
) -> Iterator[Done]:
    """Outcomes (with their parts' contents) in file order.

    With several workers the request goes to each worker process once (its
    initializer), the files in chunks of :func:`chunk_size`; at most ``2·workers``
    chunks are in flight, so memory stays flat in the number of reports.  ``claim``
    (a history store's) marks each chunk's reports just before it is handed out.
    """
    items: list[Item] = [(str(path), size, mtime, "", "") for path, size, mtime in files]
    take = claim if claim is not None else (lambda chunk: chunk)
    if workers <= 1:
        _init(work)
        for start in range(0, len(items), CHUNK):
            for item in take(items[start : start + CHUNK]):
                yield _correct_one(*item)
        return
    size = chunk_size(len(items), workers)
    chunks = (take(items[i : i + size]) for i in range(0, len(items), size))
    with ProcessPoolExecutor(
        max_workers=workers, initializer=_init_worker, initargs=(work, os.getpid(), process_started(os.getpid()))
    ) as pool:
        pending: deque[Future[list[Done]]] = deque(
            pool.submit(_correct_chunk, c) for c in itertools.islice(chunks, 2 * workers)
        )
        while pending:
            done = pending.popleft()
            nxt = next(chunks, None)
            if nxt is not None:
                pending.append(pool.submit(_correct_chunk, nxt))
            yield from done.result()


#: Fewest reports for which the automatic worker count starts processes (below it a pool's
#: start costs more than it saves).
AUTO_MIN_REPORTS = 32
#: Most processes the automatic worker count uses.
AUTO_MAX_WORKERS = 8


def auto_workers(n_files: int) -> int:
    """The worker count when none is given: one per CPU this process may run on (at most
    :data:`AUTO_MAX_WORKERS`), and 1 for fewer than :data:`AUTO_MIN_REPORTS` reports."""
    if n_files < AUTO_MIN_REPORTS:
        return 1
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, AUTO_MAX_WORKERS))


def run_batch(
    request: CorrectRequest,
    folder: str | Path,
    out: str | Path,
    *,
    workers: int | None = 1,
    controller: str = "csv",
    settle: float = 1.0,
    store: Store | None = None,
    force: bool = False,
    progress: Callable[[int, int, Outcome], None] | None = None,
    program_number: int | None = None,
    include_excluded: bool = False,
) -> BatchSummary:
    """Correct every report below ``folder`` with ``request`` and write one offsets file ``out``.

    Parameters
    ----------
    request : CorrectRequest
        As ``setupfix correct`` builds it; every report is corrected with it.
    folder : path
        Searched recursively (:func:`parsers.list_reports`); every candidate is tried
        with every reader; what cannot be listed is named in ``failed``.
    out : path
        The offsets CSV (written atomically: complete or absent), or with a
        ``controller`` other than csv a folder receiving one program per cycle, at
        :func:`~setupfix.outputs.controllers.program_path` of the report's path below
        ``folder``; its manifest (:data:`~setupfix.outputs.batch_output.MANIFEST`) lets a report that yields no program
        this run (rejected, refused, a copy of another) remove those of an earlier run.
    workers : int or None
        Processes (1: in this process; None: :func:`auto_workers`).  Results do not
        depend on it.
    settle : float
        Seconds a file must be left unchanged before it is read.
    store : Store, optional
        History store: each report is claimed in it before it is corrected
        (:class:`~setupfix.usecases.batch_records.Claims`); reports a batch processed are
        skipped (unless ``force``), and so are reports another running batch holds.  Each
        corrected report is stored with its recommendations (marked when rejected, failed
        or from a draft model) in one transaction as it is done; the mark that it was
        processed is added only after the output is written.  With the
        model's EWMA (λ < 1) the smoothing history is the store (or
        ``request.history``) plus every report of the batch (:func:`batch_history`).
    progress : callable, optional
        Called after each report with (done, total, outcome).
    program_number : int, optional
        The first program's number (``--program-number``); default each program's own
        derived number, distinct in the run (:class:`~setupfix.outputs.batch_output.ProgramNumbers`).
    include_excluded : bool
        The store's reports marked rejected, failed or draft enter the smoothing history too
        (``--include-excluded``); by default they are left out and a note says how many.

    Returns
    -------
    BatchSummary
        ``written`` is False when no report produced rows (an existing output is
        then left untouched).
    """
    start = time.perf_counter()
    model = request.model
    if workers is not None and not 1 <= workers <= 64:
        raise ParameterError(f"batch: workers must be an int in [1, 64], got {workers}")
    # An unknown controller, or a register it cannot express, fails before any work.
    render(
        controller,
        offset_rows(model, {}, current=request.current),
        program_number=program_number,
        spindle=model.spindle,
    )
    if store is not None:
        store.verify()  # a damaged store is refused before any work, not written into
    listing = find_reports(folder)
    files = [(f.path, f.size, f.mtime_ns) for f in listing.files]
    if workers is None:
        workers = auto_workers(len(files))
    if files:
        youngest = time.time() - max(m for _, _, m in files) / 1e9
        if youngest < settle:
            time.sleep(settle - youngest)
    held = stored_parts(model, store, include_excluded=include_excluded) if store is not None else []  # read once
    averaged = model.safety.ewma < 1.0 or model.safety.mean_of > 1  # the batch's earlier reports count too
    if averaged and (store is not None or request.history is not None):
        if request.history is not None:
            base = request.history
        else:
            assert store is not None  # tested above
            base = History.from_store(model, store, include_excluded=include_excluded, stored=held)
        paths = [f for f, _, _ in files]
        request = dataclasses.replace(
            request, history=batch_history(request, base, paths, include_excluded=include_excluded)
        )
    elif store is not None and request.history is None:  # the coverage stand-ins: the store's parts (as correct)
        request = dataclasses.replace(
            request, history=History.from_store(model, store, include_excluded=include_excluded, stored=held)
        )
    measured = _Measured(model, [] if force else held)
    summary = Tally()
    summary.failed += listing.problems  # named, never dropped: an unreadable folder, a broken link, …
    left_out = request.history.excluded if request.history is not None and model.safety.ewma < 1.0 else 0
    if left_out and request.history is not None:  # said once for the run, not with every report's smoothing
        request = dataclasses.replace(request, history=dataclasses.replace(request.history, excluded=0))
        note = excluded_note(left_out, "the smoothing history")
        summary.notes.append((visible_name(store.location if store is not None else "history"), note))
    summary.notes += [
        (path, Note(f"symbolic link to {target}: read as a report", None, "folder")) for path, target in listing.links
    ]
    seen: dict[str, str] = {}
    writer: CsvOut | ProgramsOut = (
        CsvOut(out)
        if controller == "csv"
        else ProgramsOut(out, controller, program_number=program_number, spindle=model.spindle)
    )
    claims = Claims(store, force) if store is not None else None
    work = _Work(request, record=store is not None, controller=controller)
    try:
        with writer:
            for i, (outcome, contents) in enumerate(
                _outcomes(files, work, workers, claims.take if claims else None), start=1
            ):
                stored = outcome.skipped == ALREADY_PROCESSED or outcome.skipped.startswith(HELD_ELSEWHERE)
                if not (outcome.error or outcome.skipped) and outcome.sha256 not in seen:
                    measured.once(outcome, contents)  # the same measurement in other bytes: used once
                account(summary, outcome, seen)
                rel = Path(outcome.path).relative_to(folder).as_posix()
                if outcome.error or (outcome.skipped and not stored):
                    writer.drop(rel)  # no program this run (refused, a copy, rewritten): none of an earlier run
                elif not outcome.skipped:
                    outcome.rows = [dataclasses.replace(r, report=visible_name(rel)) for r in outcome.rows]
                    writer.add(rel, outcome.rows, outcome.programs)
                    if claims is not None:
                        try:
                            claims.record(outcome, request.solve, final=not model.draft)
                        except SetupfixError as exc:  # its offsets stand; it is corrected again next run
                            note = Note(exc.message, exc.location, "store")
                            outcome.notes.append(note)
                            summary.notes.append((visible_name(outcome.path), note))  # counted above: said here
                    outcome.data, outcome.table = b"", None
                if progress is not None:
                    progress(i, len(files), outcome)
            written = writer.commit()
        if claims is not None:
            claims.finish()  # the output is in place: now the reports count as processed
    finally:
        if claims is not None:
            claims.release()
    return summary.summary(time.perf_counter() - start, written, claims)


class _Measured:
    """The parts a batch has used so far (and, without ``force``, those the store holds), by content.

    :meth:`once` turns a report whose every part repeats one of them into a skipped report
    naming it, and drops a repeated part of a report that has new ones (a note names it).
    """

    def __init__(self, model: ProcessModel, stored: Sequence[tuple[ReportRecord, list[PartMeasurement]]]) -> None:
        self.keys = [d.id for d in model.dimensions]
        self.index = ContentIndex()
        self.origin: list[tuple[str, str]] = []  #: (sha256, where) of each part in the index
        self.contents: list[Content] = []
        for record, parts in stored:
            for p in parts:
                try:
                    self._add(part_content(p, self.keys), record.sha256, f"{record.name} in the history store")
                except ParseError:
                    continue  # a stored time that cannot be read: that part is refused where it is used

    def _add(self, content: Content, sha: str, where: str) -> None:
        self.index.add(content)
        self.contents.append(content)
        self.origin.append((sha, where))

    def _repeats(self, content: Content, sha: str) -> str | None:
        """Where ``content`` was measured before, and its part as named there (not the stored copy of these
        very bytes); None: new."""
        return next(
            (
                f"{self.origin[i][1]} (part {self.contents[i].label!r})"
                for i in self.index.matches(content)
                if self.origin[i][0] != sha
            ),
            None,
        )

    def once(self, outcome: Outcome, contents: Sequence[Content]) -> None:
        shown = visible_name(outcome.path)
        before = [self._repeats(c, outcome.sha256) for c in contents]
        names = [c.label for c in contents]
        if contents and all(b is not None for b in before):
            outcome.skipped = f"same measurement as {before[0]}"
            return
        drop = {
            k for k, b in enumerate(before) if b is not None and names.count(names[k]) == 1
        }  # a repeated name within the report cannot be told apart in its rows: kept
        for k in sorted(drop):
            outcome.notes.append(
                Note(
                    f"part {names[k]!r} is the same measurement as {before[k]}: not corrected again",
                    SourceLocation(shown),
                    "duplicate",
                )
            )
        gone = {names[k] for k in drop}
        keep = [k for k in range(len(contents)) if k not in drop]
        outcome.parts = [outcome.parts[k] for k in keep]
        outcome.verdicts = [outcome.verdicts[k] for k in keep]
        outcome.solved = [outcome.solved[k] for k in keep]
        outcome.rows = [r for r in outcome.rows if r.part not in gone]
        outcome.programs = [(part, text) for part, text in outcome.programs if part not in gone]
        for k in keep:
            self._add(contents[k], outcome.sha256, shown)


def batch_history(
    request: CorrectRequest, base: History, files: Sequence[str | Path], *, include_excluded: bool = False
) -> History:
    """``base`` plus the parts of every report in ``files``, read as ``history import`` stores them.

    A report that cannot be read or matched adds nothing here (its correction names
    the reason); a part already held (the same measurement) is not added twice; a report
    with a part that is rejected whatever its history (:func:`rejected`) adds nothing
    either (unless ``include_excluded``): the store keeps it marked and the history leaves
    it out, as ``correct --store`` after the batch would.
    """
    parts: list[PartMeasurement] = []
    for path in files:
        try:
            read = parsers.read_report(path, **request.read.kwargs())
            found = history_parts(request.model, read.table, source=str(path))
        except (SetupfixError, OSError):
            continue
        if include_excluded or not any(rejected(request.model, p) for p in found):
            parts += found
    return base.with_parts(parts)


def rejected(model: ProcessModel, part: PartMeasurement) -> bool:
    """Whether ``part`` is rejected whatever its history: a deviation beyond the reject band that no setup
    correction explains, on the part as measured (the rule :func:`setupfix.correction.recommend.recommend`
    applies first, :func:`~setupfix.correction.recommend.beyond_band`).  A part that cannot be posed: False
    (its correction says why)."""
    try:
        posed = pose_problem(model, part)
    except SetupfixError:
        return False
    problem = posed.problem
    bad = reject_mask(posed.measured, problem.lower, problem.upper, posed.policy.reject_band)
    if not bad.any():
        return False
    stop = beyond_band(posed, bad, "exact", lambda ids: ", ".join(ids), {}, model.unit)
    return stop is not None and stop.verdict == "reject"
