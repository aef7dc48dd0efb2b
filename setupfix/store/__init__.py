"""History store: every report, correction, tool change, temperature and recommendation.

Callers see only the :class:`Store` protocol and :func:`open_store`.  Two back ends
keep the same rules, schema version and migrations: one SQLite file (:mod:`.sqlite`,
stdlib ``sqlite3``, WAL mode) -- the embedded default, no server needed -- and a
PostgreSQL database (:mod:`.postgres`, psycopg 3, the ``plant`` extra), chosen by the
location: anything that looks like a URL is a server (:mod:`.urls`: read as a URL or refused,
its password never shown), anything else a file.  A file this process cannot write (or one
opened ``read_only``) is read without being changed.
Their common queries are in :mod:`.sql`.

A store handle belongs to one machine (``machine``, default :data:`DEFAULT_MACHINE`) and
one operator (``operator``, default the login name): every report, correction,
temperature sample and recommendation it writes is that machine's, every read sees only
that machine's rows; :meth:`Store.machines` and ``audit(every_machine=True)`` see the
whole plant.  A recommendation is stored with its audit columns
(:mod:`.audit`: operator, report name and hash, part, verdict, rules, one delta per
register component, applied and exported program).

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
* a report belongs to one machine: the same bytes given for another machine are another
  record (its own rows, claims and mark);
* a report may be stored for the record but left out of the history (``excluded``: its
  verdict was reject, it could not be corrected, or the model was a draft,
  :data:`EXCLUDED_REASONS`); reading every report's rows (:meth:`Store.measurements`,
  :func:`report_tables`) leaves those out unless asked, and adding the report again with
  another mark changes the mark (the newest verdict rules);
* every failure (a damaged, read-only, locked or full file; a server that is down, refuses
  the login or is unknown; a bad URL) is a :class:`StoreError` naming the store (a URL
  without its password), never a bare database error.

Tables come and go as :class:`pandas.DataFrame` with the columns of
``../shared/spec/measurements.md`` (measurement table, corrections log, temperature
log).
"""

from __future__ import annotations

import getpass
import os
import secrets
import socket
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pandas as pd

from parsers.corrections import COLUMNS as CORRECTION_COLUMNS
from parsers.corrections import RegisterLog, check_corrections, log_from_frame
from setupfix.core.atomic import process_alive, process_started
from setupfix.model import ProcessModel
from setupfix.store.audit import AUDIT_COLUMNS
from setupfix.store.link_audit import LinkAttempt
from setupfix.store.urls import looks_like_url, shown

__all__ = [
    "Store",
    "ReportRecord",
    "Recommendation",
    "Claimant",
    "MachineSummary",
    "open_store",
    "report_tables",
    "report_rows",
    "excluded_reports",
    "EXCLUDED_REASONS",
    "stored_corrections",
    "is_server",
    "shown_location",
    "login_name",
    "CORRECTION_COLUMNS",
    "AUDIT_COLUMNS",
    "CLAIM_STALE_S",
    "ALREADY_PROCESSED",
    "HELD_ELSEWHERE",
    "DEFAULT_MACHINE",
    "DB_ENV",
]

#: The machine of a store handle opened without one (and of every row stored before machines were kept).
DEFAULT_MACHINE = "default"
#: The environment variable that names the store when no ``--db`` is given (a file path or a URL).
DB_ENV = "SETUPFIX_DB"

#: A claim from another host (whose process cannot be looked at) is stale after this long, seconds.
CLAIM_STALE_S = 12 * 3600.0
#: Why a stored report is left out of the history (``ReportRecord.excluded``): its verdict was reject,
#: it could not be corrected, or the model it was corrected with was a draft.
EXCLUDED_REASONS = ("rejected", "failed", "draft")
#: Why a report a batch already processed is skipped.
ALREADY_PROCESSED = "already processed (history store); --force corrects it again"
#: How a refusal of a report another live batch holds begins (the rest names that run).
HELD_ELSEWHERE = "being corrected by another run"


@dataclass(frozen=True)
class Claimant:
    """Who holds a claim: one run of one process (``token`` is random per run).

    ``host``, ``pid`` and ``started`` (:func:`setupfix.core.atomic.process_started`) tell whether
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
    """One stored report: its content hash, name, reader, size, rows, import time and machine.

    ``excluded`` is None when the history uses the report, else why it is left out (one of
    :data:`EXCLUDED_REASONS`).
    """

    sha256: str
    name: str
    format: str
    size: int
    rows: int
    imported_at: str
    machine: str = DEFAULT_MACHINE
    excluded: str | None = None


@dataclass(frozen=True)
class MachineSummary:
    """What the store holds for one machine (``history show``): counts and first/last times (ISO text)."""

    machine: str
    reports: int = 0
    rows: int = 0
    first_measured: str | None = None
    last_measured: str | None = None
    last_import: str | None = None
    corrections: int = 0
    tool_changes: int = 0
    temperature_samples: int = 0
    temperature_channels: int = 0
    recommendations: int = 0
    last_recommendation: str | None = None


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
    machine, operator : str
        Whose it is; set by the store (its handle's machine and operator) -- given values are ignored.
    """

    optimizer: str
    inputs: Mapping[str, Any]
    result: Mapping[str, Any]
    created_at: str = ""
    machine: str = ""
    operator: str = ""


class Store(Protocol):
    """What the rest of setupfix may ask of a history store (of one machine, written by one operator)."""

    location: str
    machine: str
    operator: str

    def transaction(self) -> AbstractContextManager[None]:
        """Everything inside is committed together at the end, or rolled back on any exception."""
        ...

    def add_report(
        self, data: bytes, name: str, format: str, table: pd.DataFrame, *, excluded: str | None = None
    ) -> tuple[str, bool]:
        """Store a report (its bytes' hash, name, reader) and its canonical rows; (sha256, newly added).

        ``excluded`` (None or one of :data:`EXCLUDED_REASONS`) marks it left out of the history; a
        report stored before takes the mark given now.
        """
        ...

    def report(self, sha256: str) -> ReportRecord | None:
        """The stored report with this content hash, if any."""
        ...

    def reports(self) -> list[ReportRecord]:
        """Every stored report of this machine in import order, excluded ones too (see ``excluded``)."""
        ...

    def measurements(self, sha256: str | None = None, *, include_excluded: bool = False) -> pd.DataFrame:
        """Canonical rows of one report (whatever its mark), or of all in import order (the excluded ones
        only when ``include_excluded``), plus ``reference`` and ``report_sha256``."""
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
        """Every stored recommendation of this machine, oldest first."""
        ...

    def audit(self, *, every_machine: bool = False) -> pd.DataFrame:
        """The audit trail (:data:`AUDIT_COLUMNS`): one row per register component of each recommendation
        (one row with no register for a recommendation without one), oldest first; this machine's, or the plant's."""
        ...

    def machines(self) -> list[MachineSummary]:
        """What the store holds for each machine, by machine name (one aggregate query per table)."""
        ...

    def dump(self, table: str) -> Iterator[tuple[Any, ...]]:
        """Every row of one table as stored, every machine (``history migrate``)."""
        ...

    def count(self, table: str) -> int:
        """Rows of one table, every machine."""
        ...

    def restore(self, table: str, rows: Iterable[Sequence[Any]]) -> None:
        """Insert rows :meth:`dump` gave, as they are, ids included (inside the caller's transaction when open)."""
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

    def add_link_attempt(self, attempt: LinkAttempt) -> int:
        """Record one ``machine write`` attempt (:mod:`setupfix.store.link_audit`); its id."""
        ...

    def link_attempts(self, *, every_machine: bool = False) -> list[LinkAttempt]:
        """The recorded ``machine write`` attempts in order (this machine's unless ``every_machine``)."""
        ...

    def close(self) -> None: ...

    def __enter__(self) -> Store: ...

    def __exit__(self, *exc: object) -> None: ...


def is_server(location: str | os.PathLike[str]) -> bool:
    """Whether ``location`` names a PostgreSQL database: anything that looks like a URL
    (:func:`setupfix.store.urls.looks_like_url`: ``postgresql://``, ``PostgreSQL://``,
    `` postgres:/…``, ``mysql://…``), which :func:`open_store` reads as one or refuses, never a file."""
    return looks_like_url(os.fspath(location))


def shown_location(location: str | os.PathLike[str]) -> str:
    """``location`` as any message may print it: a URL without its password and query, a path as given."""
    return shown(os.fspath(location))


def login_name() -> str:
    """The operator of a store handle opened without one: the login name ("" when the system cannot say)."""
    try:
        return getpass.getuser()
    except (OSError, KeyError):
        return ""


def open_store(
    location: str | os.PathLike[str],
    *,
    machine: str | None = None,
    operator: str | None = None,
    read_only: bool = False,
) -> Store:
    """Open (creating and migrating when needed) the history store at ``location``, for one machine.

    Parameters
    ----------
    location : str or path
        A file (SQLite) or a ``postgresql://user:password@host:port/database`` URL.
    machine : str, optional
        The machine every row written belongs to and every read is limited to;
        :data:`DEFAULT_MACHINE` when None or empty.
    operator : str, optional
        Who writes (stored with each recommendation); the login name when None.
    read_only : bool
        Never change the store (``history migrate``'s source): it is checked whole first (a
        damaged, empty or incomplete one is refused), read as it is (an older schema is read
        through a migrated copy), and every write is a :class:`StoreError`.  A file this process
        cannot write (read-only file, folder or mount) is opened read-only whatever this says.

    Raises
    ------
    StoreError
        Naming the store: a file that is not a setupfix store, was written by a newer
        setupfix, is damaged or cannot be opened or created (read-only, locked, full); a
        server that cannot be reached, refuses the login or has no such database; a URL
        that cannot be read; psycopg not installed (the ``plant`` extra).
    """
    who = (machine or "").strip() or DEFAULT_MACHINE
    by = login_name() if operator is None else operator
    if is_server(location):
        from setupfix.store.postgres import PostgresStore

        return PostgresStore(str(location), machine=who, operator=by, read_only=read_only)
    from setupfix.store.sqlite import SQLiteStore

    return SQLiteStore(os.fspath(location), machine=who, operator=by, read_only=read_only)


def report_tables(store: Store, *, include_excluded: bool = False) -> list[tuple[ReportRecord, pd.DataFrame]]:
    """Every stored report with its canonical rows (and ``reference`` flags), in import order: one query.

    The one way the doors read a store's reports (``correct --store``'s smoothing,
    ``diagnose --db``, the TUI's history).  Reports marked excluded (rejected, failed, draft)
    are left out unless ``include_excluded`` (:func:`excluded_reports` names them).
    """
    records = {r.sha256: r for r in store.reports()}
    rows = store.measurements(include_excluded=include_excluded)  # in import order, each report's rows together
    keys = rows.pop("report_sha256").to_numpy()
    if not len(keys):
        return []
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    ends = np.r_[starts[1:], len(keys)]
    return [(records[str(keys[a])], rows.iloc[a:b]) for a, b in zip(starts, ends, strict=True)]


def report_rows(
    store: Store, *, include_excluded: bool = False
) -> tuple[list[ReportRecord], pd.DataFrame, np.ndarray[Any, np.dtype[np.int64]]]:
    """:func:`report_tables` as one frame: (each report's record, all their rows, each report's first row).

    The same rows in the same order as :func:`report_tables` (``report_sha256`` dropped), for a
    reader that handles a machine's whole history at once instead of 8,760 per-report slices.
    """
    records = {r.sha256: r for r in store.reports()}
    rows = store.measurements(include_excluded=include_excluded)
    keys = rows.pop("report_sha256").to_numpy()
    if not len(keys):
        return [], rows, np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]).astype(np.int64)
    return [records[str(k)] for k in keys[starts]], rows, starts


def excluded_reports(store: Store) -> list[ReportRecord]:
    """The reports of the store's machine left out of the history (``excluded`` set), in import order."""
    return [r for r in store.reports() if r.excluded is not None]


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
