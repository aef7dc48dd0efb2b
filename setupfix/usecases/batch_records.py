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
from collections import Counter
from collections.abc import Mapping
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

__all__ = ["Outcome", "BatchSummary", "Tally", "Claims", "Item", "account"]


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

    def to_json(self) -> dict[str, Any]:
        return {
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

    def summary(self, seconds: float, written: bool) -> BatchSummary:
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
        )


#: One report for a worker: path, size and modification time when listed, the content hash it was
#: claimed under ("" without a store) and why it is not to be corrected ("" to correct it).
Item = tuple[str, int, int, str, str]


class Claims:
    """A batch's claims in the history store: taken chunk by chunk, finished once the output is written.

    The claim is keyed by the content hash of the bytes read here; the worker reads the
    file again and corrects it only if its hash is the one claimed.  Recommendations wait
    in memory (a verdict and a few numbers per part) and are stored, with the claims
    turned into "processed", in one transaction by :meth:`finish`; :meth:`release` frees
    whatever is still held (a failure, an interrupt), so those reports are corrected by
    the next run.  A SIGKILL leaves the claims behind: the next run takes them over (the
    process is gone, :meth:`setupfix.store.Claimant.gone`).
    """

    def __init__(self, store: Store, force: bool) -> None:
        self.store, self.force = store, force
        self.claimant = Claimant.this_run()
        self.pending: list[tuple[str, list[StoreRecommendation], bool]] = []
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
        refused = self.store.claim_reports([h for _, _, _, h, _ in hashed if h], self.claimant, again=self.force)
        return [(p, n, m, h, refused.get(h, "")) for p, n, m, h, _ in hashed]

    def record(self, outcome: Outcome, solve: SolveOptions, *, final: bool = True) -> None:
        """Keep ``outcome``'s recommendations for :meth:`finish`; ``final=False`` (a draft model's holds)
        stores them but leaves the report unprocessed, so the run after the model's edit corrects it."""
        self.pending.append((outcome.sha256, _record(self.store, outcome, solve), all(outcome.solved) and final))

    def finish(self) -> None:
        try:
            with self.store.transaction():
                for _, recs, _ in self.pending:
                    for rec in recs:
                        self.store.add_recommendation(rec)
                # a report with a part not solved within the time limit stays unprocessed: release() frees its
                # claim and the next run corrects it again
                self.store.finish_claims([sha for sha, _, solved in self.pending if solved], self.claimant)
        except StoreError as exc:
            raise StoreError(
                exc.message,
                location=exc.location,
                hint="the output was written; its reports are not marked processed in the store and "
                "are corrected again by the next run",
            ) from None
        self.pending = []

    def release(self) -> None:
        if not self.held:
            return
        with contextlib.suppress(SetupfixError):  # what cannot be freed now is taken over as stale later
            self.store.release_claims(self.claimant)
        self.held = False


def _record(store: Store, outcome: Outcome, solve: SolveOptions) -> list[StoreRecommendation]:
    """Add the report (the bytes and table the worker corrected, not a second reading); its recommendations."""
    assert outcome.table is not None
    sha, _ = store.add_report(outcome.data, visible_name(Path(outcome.path).name), outcome.format, outcome.table)
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
