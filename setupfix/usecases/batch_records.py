"""What a batch keeps of each report: its outcome, the run's summary, and its claims in the history store.

:class:`Outcome` is one report's result as a worker returns it; :class:`BatchSummary` the
counts of a run, built once at its end from the running :class:`Tally`
(:func:`account` adds an outcome: a copy of a report already corrected in this run is
skipped, every note kept with its file).  :class:`Claims` holds a run's claims in the
history store (see its docstring): each report is claimed before it is corrected, and
counts as processed only once the output is written.
"""

from __future__ import annotations

import contextlib
import hashlib
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from parsers.names import visible_name
from setupfix.core.errors import Note, SetupfixError, StoreError
from setupfix.correction.offsets import OffsetRow
from setupfix.store import Claimant, Store
from setupfix.store import Recommendation as StoreRecommendation
from setupfix.usecases.requests import SolveOptions

__all__ = ["Outcome", "BatchSummary", "Tally", "Claims", "Item", "account", "exclusion"]


@dataclass
class Outcome:
    """One report's result: its offset rows and verdicts, or why it failed."""

    path: str
    sha256: str = ""
    rows: list[OffsetRow] = field(default_factory=list)
    verdicts: list[str] = field(default_factory=list)
    parts: list[str] = field(default_factory=list)
    #: per verdict: False for a cycle whose solve was stopped with nothing proven (not stored as done)
    solved: list[bool] = field(default_factory=list)
    error: str = ""
    skipped: str = ""
    format: str = ""
    notes: list[Note] = field(default_factory=list)
    programs: list[tuple[str, str]] = field(default_factory=list)  #: (part, program) of every cycle not rejected
    data: bytes = b""  #: the bytes corrected (only with a history store)
    table: pd.DataFrame | None = None  #: the canonical table read from them (only with ``record``)


@dataclass(frozen=True, eq=False)
class BatchSummary:
    """Counts and failures of one batch run, built once at its end.

    ``verdicts`` counts the verdicts (a missing one counts 0); ``unsolved`` the holds
    whose solve was stopped with nothing proven (time limit); ``failed`` and
    ``skipped`` are (file, reason) pairs; ``notes`` (file, note) pairs, typed.
    """

    reports: int = 0
    parts: int = 0
    verdicts: Mapping[str, int] = field(default_factory=Counter)
    failed: tuple[tuple[str, str], ...] = ()
    skipped: tuple[tuple[str, str], ...] = ()
    seconds: float = 0.0
    written: bool = False
    notes: tuple[tuple[str, Note], ...] = ()
    unsolved: int = 0
    #: with a history store: the reports this run stored, each with its recommendations (None: no store)
    stored: int | None = None
    #: of those, how many were marked excluded, by reason (``rejected``, ``failed``, ``draft``)
    excluded: Mapping[str, int] = field(default_factory=Counter)

    def to_json(self) -> dict[str, Any]:
        store = {} if self.stored is None else {"stored": self.stored, "excluded": dict(self.excluded)}
        return {
            **store,
            "reports": self.reports,
            "parts": self.parts,
            "verdicts": dict(self.verdicts),
            "unsolved": self.unsolved,
            "failed": [{"file": f, "reason": r} for f, r in self.failed],
            "skipped": [{"file": f, "reason": r} for f, r in self.skipped],
            "notes": [{"file": f, "note": str(n)} for f, n in self.notes],
            "seconds": round(self.seconds, 3),
            "written": self.written,
        }


@dataclass
class Tally:
    """The batch's counts while the reports stream in (private: :class:`BatchSummary` is the outcome)."""

    reports: int = 0
    parts: int = 0
    verdicts: Counter[str] = field(default_factory=Counter)
    failed: list[tuple[str, str]] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)
    notes: list[tuple[str, Note]] = field(default_factory=list)
    unsolved: int = 0
    stored: int | None = None
    excluded: Counter[str] = field(default_factory=Counter)

    def summary(self, seconds: float, written: bool, claims: Claims | None = None) -> BatchSummary:
        """The run's summary; with the history store's ``claims``, what they stored."""
        return BatchSummary(
            self.reports,
            self.parts,
            Counter(self.verdicts),
            tuple(self.failed),
            tuple(self.skipped),
            seconds,
            written,
            tuple(self.notes),
            self.unsolved,
            claims.stored if claims is not None else self.stored,
            Counter(claims.excluded) if claims is not None else Counter(self.excluded),
        )


#: One report for a worker: path, size and modification time when listed, the content hash it was
#: claimed under ("" without a store) and why it is not to be corrected ("" to correct it).
Item = tuple[str, int, int, str, str]


class Claims:
    """A batch's claims in the history store: taken chunk by chunk, finished once the output is written.

    The claim is keyed by the content hash of the bytes read here; the worker reads the
    file again and corrects it only if its hash is the one claimed.  Each corrected report
    is stored with its recommendations in one transaction as it is done (:meth:`record`),
    marked (:func:`exclusion`) when the history is to leave it out, so a failure at any
    point leaves whole reports behind, each with its recommendations, and says how many
    (:attr:`stored`).  The claims are turned into "processed" in one transaction by
    :meth:`finish`, once the output is written; :meth:`release` frees whatever is still
    held (a failure, an interrupt), so those reports are corrected by the next run (which
    adds its own recommendations; the report's rows are not stored twice, and the newest
    verdict sets its mark).  A
    SIGKILL leaves the claims behind: the next run takes them over (the process is gone,
    :meth:`setupfix.store.Claimant.gone`).
    """

    def __init__(self, store: Store, force: bool) -> None:
        self.store, self.force = store, force
        self.claimant = Claimant.this_run()
        self.done: list[str] = []  #: reports stored, to be marked processed by finish()
        self.stored = 0  #: reports stored with their recommendations by this run
        self.excluded: Counter[str] = Counter()  #: of those, the ones marked excluded, by reason
        self.held = False

    def take(self, chunk: list[Item]) -> list[Item]:
        """``chunk`` with each report's claimed hash, or why it is not to be corrected."""
        hashed: list[Item] = []
        for path, size, mtime, _, _ in chunk:
            try:
                with open(path, "rb") as f:
                    sha = hashlib.sha256(f.read()).hexdigest()
            except OSError:
                sha = ""  # the worker reads it and says why it cannot
            hashed.append((path, size, mtime, sha, ""))
        self.held = True
        try:
            refused = self.store.claim_reports([h for _, _, _, h, _ in hashed if h], self.claimant, again=self.force)
        except StoreError as exc:
            raise self._failed(exc, "no output was written") from None
        return [(p, n, m, h, refused.get(h, "")) for p, n, m, h, _ in hashed]

    def record(self, outcome: Outcome, solve: SolveOptions, *, final: bool = True) -> None:
        """Store ``outcome``'s report with its recommendations, one transaction; ``final=False`` (a draft
        model) marks it ``draft`` and leaves it unprocessed, so the run after the model's edit corrects it.

        Raises
        ------
        StoreError
            Nothing of this report was stored (the reports before it are).
        """
        excluded = exclusion(outcome.verdicts, outcome.solved, draft=not final)
        with self.store.transaction():  # a failure here stores nothing of this report (said per report)
            for rec in _record(self.store, outcome, solve, excluded):
                self.store.add_recommendation(rec)
        self.stored += 1
        if excluded is not None:
            self.excluded[excluded] += 1
        # a report with a part not solved within the time limit stays unprocessed: release() frees its
        # claim and the next run corrects it again
        if all(outcome.solved) and final:
            self.done.append(outcome.sha256)

    def finish(self) -> None:
        try:
            with self.store.transaction():
                self.store.finish_claims(self.done, self.claimant)
        except StoreError as exc:
            raise self._failed(exc, "the output was written") from None
        self.done = []

    def _failed(self, exc: StoreError, output: str) -> StoreError:
        """``exc`` saying what this run stored: whole reports with their recommendations, none processed."""
        return StoreError(
            f"{_cause(exc)}; {self.stored} report(s) of this run were stored, each with its recommendations, "
            "none marked processed",
            location=exc.location,
            hint=f"{output}; the reports are corrected again by the next run",
        )

    def release(self) -> None:
        if not self.held:
            return
        with contextlib.suppress(SetupfixError):  # what cannot be freed now is taken over as stale later
            self.store.release_claims(self.claimant)
        self.held = False


def _cause(exc: StoreError) -> str:
    """What went wrong, without a back end's claim about what the failed transaction left (said here)."""
    return re.sub(
        r"; (nothing( of the current import)? was stored|the transaction under way was not stored)$", "", exc.message
    )


def exclusion(verdicts: Sequence[str], solved: Sequence[bool], *, draft: bool) -> str | None:
    """Why the history leaves a corrected report out (:data:`setupfix.store.EXCLUDED_REASONS`), or None.

    ``draft``: the model was a draft (its verdicts are not to be trusted); ``rejected``: a part's
    verdict was reject (a gross error, a setup error); ``failed``: a part could not be corrected
    (its solve stopped with nothing proven).  The first that holds, in this order.  ``verdicts``
    and ``solved`` are the report's parts'; batch and ``correct --store`` mark by this one rule.
    """
    if draft:
        return "draft"
    if "reject" in verdicts:
        return "rejected"
    if not all(solved):
        return "failed"
    return None


def _record(store: Store, outcome: Outcome, solve: SolveOptions, excluded: str | None) -> list[StoreRecommendation]:
    """Add the report (the bytes and table the worker corrected, not a second reading) with its mark;
    its recommendations."""
    assert outcome.table is not None
    name = visible_name(Path(outcome.path).name)
    sha, _ = store.add_report(outcome.data, name, outcome.format, outcome.table, excluded=excluded)
    by_part: dict[str, dict[str, float]] = {}
    for row in outcome.rows:
        by_part.setdefault(row.part, {})[row.id] = row.delta
    # One recommendation per corrected part, its verdict beside it (a part with no offset row -- every
    # register fixed -- still gets its verdict, and no verdict slides onto the next part).
    return [
        StoreRecommendation(
            optimizer=solve.optimizer,
            inputs={"use": "batch", "report": sha, "part": part, "seed": solve.seed},
            result={"verdict": verdict, "corrections": by_part.get(part, {}), "solved": solved},
        )
        for part, verdict, solved in zip(outcome.parts, outcome.verdicts, outcome.solved, strict=True)
    ]


def account(summary: Tally, outcome: Outcome, seen: dict[str, str]) -> None:
    shown = visible_name(outcome.path)  # what the summary says: printable, whatever the file's name
    if outcome.error:
        summary.failed.append((shown, outcome.error))
        return
    if not outcome.skipped and outcome.sha256 in seen:
        outcome.skipped = f"same content as {seen[outcome.sha256]}"
    if outcome.skipped:
        summary.skipped.append((shown, outcome.skipped))
        if outcome.skipped.startswith("still being written"):
            summary.failed.append((shown, outcome.skipped))
        return
    seen[outcome.sha256] = shown
    summary.notes += [(shown, n) for n in outcome.notes]
    summary.reports += 1
    summary.parts += len(outcome.verdicts)
    summary.verdicts.update(outcome.verdicts)
    summary.unsolved += outcome.solved.count(False)
