"""History store: every report, correction, tool change, temperature and recommendation.

Callers see only the :class:`Store` protocol and :func:`open_store`; the embedded
default is one SQLite file (:mod:`setupfix.store._sqlite`, stdlib ``sqlite3``, WAL
mode, schema versioned with migrations).  A server database can be added later as
another implementation of the same protocol, chosen by :func:`open_store` from the
location given, without touching callers.

Rules every implementation keeps:

* reports are keyed by the SHA-256 of their bytes: adding the same report twice
  changes nothing;
* corrections and temperature samples are keyed by (timestamp, register, event) and
  (timestamp, sensor): a repeated row changes nothing, a row that contradicts a stored
  one (another delta or value at the same key) is refused with :class:`StoreError`;
* everything done inside one ``with store.transaction():`` is stored together or not
  at all (a failure or a kill leaves the store as it was);
* readers in other processes see the last committed state while one process writes;
* a batch claims each report before correcting it (:meth:`Store.claim_reports`, one
  transaction per group of reports): a report is corrected by one run at a time and,
  once a run has written its output and finished its claims, by no later run unless
  forced.  A claim names its run (random token), host, pid, the process's start mark
  and time; a claim whose process is gone (same host: the pid is not running or is
  another process; another host: older than :data:`CLAIM_STALE_S`) is taken over;
* every failure of the file (damaged, read-only, locked beyond the busy timeout, full)
  is a :class:`StoreError` naming the store, never a bare database error.

Tables come and go as :class:`pandas.DataFrame` with the columns of
``../shared/spec/measurements.md`` (measurement table, corrections log, temperature
log).
"""

from __future__ import annotations

import os
import secrets
import socket
from collections.abc import Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any, Protocol

import pandas as pd

from parsers.corrections import COLUMNS as CORRECTION_COLUMNS
from parsers.corrections import RegisterLog, check_corrections, log_from_frame
from setupfix.atomic import process_alive, process_started
from setupfix.model import ProcessModel

__all__ = ["Store", "ReportRecord", "Recommendation", "Claimant", "open_store", "report_tables",
           "stored_corrections", "CORRECTION_COLUMNS", "CLAIM_STALE_S", "ALREADY_PROCESSED",
           "HELD_ELSEWHERE"]

#: A claim from another host (whose process cannot be looked at) is stale after this long, seconds.
CLAIM_STALE_S = 12 * 3600.0
#: Why a report a batch already processed is skipped.
ALREADY_PROCESSED = "already processed (history store); --force corrects it again"
#: How a refusal of a report another live batch holds begins (the rest names that run).
HELD_ELSEWHERE = "being corrected by another run"


@dataclass(frozen=True)
class Claimant:
    """Who holds a claim: one run of one process (``token`` is random per run).

    ``host``, ``pid`` and ``started`` (:func:`setupfix.atomic.process_started`) tell whether
    its process still runs, for a claim left by a run that was killed.
    """

    token: str
    host: str
    pid: int
    started: str

    @classmethod
    def this_run(cls) -> Claimant:
        """A new claimant for a run of this process."""
        pid = os.getpid()
        return cls(secrets.token_hex(8), socket.gethostname(), pid, process_started(pid))

    def gone(self, age_s: float) -> bool:
        """Whether this claimant's process has ended: on this host, asked of the system; on another
        host, assumed when the claim is older than :data:`CLAIM_STALE_S`."""
        if self.host == socket.gethostname():
            return not process_alive(self.pid, self.started)
        return age_s > CLAIM_STALE_S

    def __str__(self) -> str:
        return f"process {self.pid} on {self.host}"



@dataclass(frozen=True)
class ReportRecord:
    """One stored report: its content hash, name, reader, size, rows and import time."""

    sha256: str
    name: str
    format: str
    size: int
    rows: int
    imported_at: str


@dataclass(frozen=True)
class Recommendation:
    """One correction setupfix recommended.

    Attributes
    ----------
    optimizer : str
        Registry name of the optimiser.
    inputs : mapping
        What it was computed from (model and report hashes, part, seed, options), JSON-able.
    result : mapping
        The result as written by ``--json`` (``cli-json.md``), JSON-able.
    created_at : str
        ISO 8601 time of the recommendation; set by the store when empty.
    """

    optimizer: str
    inputs: Mapping[str, Any]
    result: Mapping[str, Any]
    created_at: str = ""


class Store(Protocol):
    """What the rest of setupfix may ask of a history store."""

    location: str

    def transaction(self) -> AbstractContextManager[None]:
        """Everything inside is committed together at the end, or rolled back on any exception."""
        ...

    def add_report(self, data: bytes, name: str, format: str, table: pd.DataFrame) -> tuple[str, bool]:
        """Store a report (its bytes' hash, name, reader) and its canonical rows; (sha256, newly added)."""
        ...

    def report(self, sha256: str) -> ReportRecord | None:
        """The stored report with this content hash, if any."""
        ...

    def reports(self) -> list[ReportRecord]:
        """Every stored report in import order."""
        ...

    def measurements(self, sha256: str | None = None) -> pd.DataFrame:
        """Canonical rows of one report (or all, in import order) plus ``reference`` and ``report_sha256``."""
        ...

    def add_corrections(self, log: pd.DataFrame) -> int:
        """Store corrections-log rows (:data:`CORRECTION_COLUMNS`); the number of new rows."""
        ...

    def corrections(self, event: str | None = None) -> pd.DataFrame:
        """Corrections log in time order (only ``event`` rows when given, e.g. ``"tool_change"``)."""
        ...

    def add_temperatures(self, log: pd.DataFrame) -> int:
        """Store a temperature log (``timestamp`` and one column per channel); the number of new values."""
        ...

    def temperatures(self) -> pd.DataFrame:
        """Temperature log in time order, one column per channel (NaN where a channel has no sample)."""
        ...

    def add_recommendation(self, rec: Recommendation) -> int:
        """Store a recommendation; its id."""
        ...

    def recommendations(self) -> list[Recommendation]:
        """Every stored recommendation, oldest first."""
        ...

    def claim_reports(self, keys: Sequence[str], claimant: Claimant, *, again: bool = False) -> dict[str, str]:
        """Claim every report (content hash) of ``keys`` in one transaction; {key: why not} for the others.

        Not claimed: a report a batch processed (:data:`ALREADY_PROCESSED`) unless ``again``,
        and one another live run holds.  A claim of a run whose process is gone is taken over.
        """
        ...

    def finish_claims(self, keys: Sequence[str], claimant: Claimant) -> None:
        """Mark ``keys`` (held by ``claimant``) processed and free (inside the caller's transaction)."""
        ...

    def release_claims(self, claimant: Claimant) -> None:
        """Free every claim ``claimant`` still holds (nothing is marked processed)."""
        ...

    def verify(self) -> None:
        """Check the whole store for damage (reads every page: for commands that present it all).

        Raises
        ------
        StoreError
            Naming the store, when any part of it is damaged.
        """
        ...

    def close(self) -> None:
        ...

    def __enter__(self) -> Store:
        ...

    def __exit__(self, *exc: object) -> None:
        ...


def open_store(path: str | os.PathLike[str]) -> Store:
    """Open (creating and migrating when needed) the history store at ``path``.

    Raises
    ------
    StoreError
        If the file is not a setupfix store, was written by a newer setupfix, is damaged,
        or cannot be opened or created (read-only, locked, full), naming the file.
    """
    from setupfix.store._sqlite import SQLiteStore

    return SQLiteStore(os.fspath(path))


def report_tables(store: Store) -> list[tuple[ReportRecord, pd.DataFrame]]:
    """Every stored report with its canonical rows (and ``reference`` flags), in import order: one query.

    The one way the doors read a store's reports (``correct --store``'s smoothing,
    ``diagnose --db``, the TUI's history).
    """
    records = {r.sha256: r for r in store.reports()}
    rows = store.measurements()
    return [(records[str(sha)], table.drop(columns=["report_sha256"]))
            for sha, table in rows.groupby("report_sha256", sort=False)]


def stored_corrections(store: Store, model: ProcessModel) -> RegisterLog | None:
    """The store's corrections log through the one reader and the one model check; None when it holds none.

    Every door that uses a store's log (``correct --store``'s smoothing, ``batch --store``,
    ``diagnose --db``) reads it here, so a row is accepted or refused alike and named
    at the same place (``<store>#corrections``, ``row N``).

    Raises
    ------
    ParseError, MatchError
        :func:`parsers.corrections.log_from_frame`, :func:`parsers.corrections.check_corrections`
        (e.g. a register the model does not know).
    """
    stored = store.corrections()
    if stored.empty:
        return None
    return check_corrections(log_from_frame(stored, f"{store.location}#corrections"), model)
