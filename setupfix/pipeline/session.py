"""Use case "operator session": what the operator's screen asks of the pipeline.

Open a report against a model — its corrections, or, when the report and the model
do not match, the match table with suggestions instead of an error — and find the
newest report in a watched folder once its writer has finished with it.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import parsers
from setupfix.errors import MatchError, ParseError, SourceLocation
from setupfix.model import ProcessModel, load_model
from setupfix.model.measurements import match_parts
from setupfix.optimize import CorrectionProblem, get_optimizer
from setupfix.pipeline.compare import DEFAULT_METHODS, Comparison, compare_problem
from setupfix.pipeline.correct import PartCorrection, assign_stations, correct_part
from setupfix.pipeline.view import MatchRow, match_rows

__all__ = ["OpenedReport", "open_report", "newest_report", "FolderWatch", "SKIPPED_SUFFIXES", "compare_steps"]


@dataclass(frozen=True)
class OpenedReport:
    """A report opened against a model.

    Either ``corrections`` (one per cycle) is filled, or ``mismatch`` holds the match
    table and ``problem`` the reason the report could not be tied to the model.
    """

    model: ProcessModel
    report: str
    format: str
    corrections: tuple[PartCorrection, ...] = ()
    mismatch: tuple[MatchRow, ...] = ()
    problem: str = ""
    notes: tuple[str, ...] = field(default=())


def open_report(model: ProcessModel | str | Path, report: str | Path, *, optimizer: str = "exact",
                seed: int | None = None) -> OpenedReport:
    """Read ``report`` (any supported format), tie it to ``model`` and correct every cycle.

    Raises
    ------
    SetupfixError
        When the model or the report cannot be read (a report that does not match the
        model is not an error: see :class:`OpenedReport`).
    """
    if not isinstance(model, ProcessModel):
        model = load_model(model)
    path = Path(report)
    if path.is_dir():
        raise ParseError("is a folder, not a report", location=SourceLocation(str(report)))
    spec = parsers.find_format(path)
    table = spec.read(path)
    try:
        table = assign_stations(model, table)
        parts = match_parts(model, table, source=str(report))
    except MatchError as exc:
        return OpenedReport(model, str(report), spec.name, mismatch=tuple(match_rows(model, table)),
                            problem=str(exc))
    corrections = tuple(correct_part(model, p, optimizer=optimizer, seed=seed) for p in parts)
    return OpenedReport(model, str(report), spec.name, corrections=corrections)


#: Files a watched folder ignores: partial downloads, editor and temporary files.
SKIPPED_SUFFIXES: tuple[str, ...] = (".tmp", ".part", ".partial", ".crdownload", "~", ".swp", ".lock")


def newest_report(folder: str | Path) -> Path | None:
    """The most recently modified report candidate in ``folder`` (not recursive).

    Hidden files, sub-folders and :data:`SKIPPED_SUFFIXES` are ignored; whether the
    file is a report is for the reader to say.
    """
    best: tuple[float, str] | None = None
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return None
    for entry in entries:
        if entry.name.startswith(".") or entry.name.endswith(SKIPPED_SUFFIXES):
            continue
        try:
            if not entry.is_file(follow_symlinks=False):
                continue
            key = (entry.stat().st_mtime, entry.name)
        except OSError:
            continue
        if best is None or key > best:
            best = key
    return None if best is None else Path(folder) / best[1]


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
        """The newest finished report not handed out before, else None."""
        path = newest_report(self.folder)
        if path is None:
            self._pending = None
            return None
        stamp = self._stamp(path)
        if stamp is None or (str(path), *stamp) in self._done:
            return None
        if self._pending == (path, *stamp) or time.time() - stamp[1] / 1e9 >= self.settle:
            self._done.add((str(path), *stamp))
            self._pending = None
            return path
        self._pending = (path, *stamp)
        return None


def compare_steps(problem: CorrectionProblem, *, methods: Sequence[str] = DEFAULT_METHODS, trials: int = 12,
                  seed: int = 0) -> Iterator[tuple[str, Comparison]]:
    """:func:`~setupfix.pipeline.compare.compare_problem` one method at a time.

    Yields ``(step, comparison so far)`` after the exact optimum (step ``"exact"``) and
    after each method, so a caller can show progress and stop between methods; the
    last comparison equals ``compare_problem(problem, methods=…, trials=…, seed=…)``.
    """
    exact = get_optimizer("exact").solve(problem)
    done = Comparison(problem=problem, exact=exact, methods=[], seed=seed, trials=trials)
    yield "exact", done
    for name in methods:
        step = compare_problem(problem, methods=[name], trials=trials, seed=seed, exact=exact)
        done = Comparison(problem=problem, exact=exact, methods=[*done.methods, *step.methods], seed=seed,
                          trials=trials, skipped={**done.skipped, **step.skipped})
        yield name, done
