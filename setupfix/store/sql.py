"""What both history stores do alike: the :class:`~setupfix.store.Store` rules in portable SQL.

:class:`SQLStore` holds every query but the batch claims' (:mod:`.claims`); a back end
(:mod:`.sqlite`, :mod:`.postgres`) gives the connection, how a transaction begins, how a
failure is named (:meth:`SQLStore._failure`), how many rows are loaded at once, and the few
words its SQL spells otherwise.  Statements are written with ``?`` placeholders (the
PostgreSQL store turns them into ``%s``).

Concurrency is the same on both: a report is inserted ``ON CONFLICT (sha256) DO NOTHING`` (a
second process importing the same bytes at once waits for the first and then adds
nothing); log rows are inserted ``ON CONFLICT DO NOTHING`` and only then compared with
what is stored (a contradicting row another process committed meanwhile is seen and
refused); a claim row is created first and then read ``FOR UPDATE`` (PostgreSQL; SQLite's
``BEGIN IMMEDIATE`` already serialises writers), keys in sorted order so two batches
never wait for each other in a circle.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from datetime import UTC, datetime
from typing import Any, Concatenate, ParamSpec, TypeVar

import pandas as pd

from setupfix.core.errors import SourceLocation, StoreError
from setupfix.model import CANONICAL_COLUMNS
from setupfix.store import (
    AUDIT_COLUMNS,
    CORRECTION_COLUMNS,
    EXCLUDED_REASONS,
    MachineSummary,
    Recommendation,
    ReportRecord,
    Store,
)
from setupfix.store.audit import TABLES, audit_of
from setupfix.store.link_audit import LinkAuditStore

__all__ = ["SQLStore", "guarded", "now"]

NUMERIC = ("nominal", "actual", "deviation", "lower", "upper", "x", "y", "z")
_TEXT = frozenset(c for c in CANONICAL_COLUMNS if c not in NUMERIC)

_S = TypeVar("_S", bound="SQLStore")
_P = ParamSpec("_P")
_R = TypeVar("_R")


def now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def guarded(method: Callable[Concatenate[_S, _P], _R]) -> Callable[Concatenate[_S, _P], _R]:
    """A store method whose database failures are one :class:`StoreError` naming the store."""

    def run(self: _S, /, *args: _P.args, **kwargs: _P.kwargs) -> _R:
        try:
            return method(self, *args, **kwargs)
        except self.errors as exc:
            raise self._failure(exc) from None

    functools.update_wrapper(run, method)
    return run


def _cell(value: Any, text: bool) -> Any:
    """A DataFrame cell as a database value: NaN/None/"" → NULL, numbers as float, text as str."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    if text:
        return str(value) if str(value) != "" else None
    return float(value)


class SQLStore(LinkAuditStore, Store):
    """The store's queries over a DB-API connection; a back end fills in the hooks below."""

    #: The driver's exceptions that :func:`guarded` turns into :class:`StoreError`.
    errors: tuple[type[BaseException], ...] = ()
    #: How the back end spells "not the same value, NULL included" and a value as comparable text.
    distinct = "IS NOT"
    #: Appended to the claim row's SELECT to lock it until the transaction ends.
    lock = ""

    location: str
    machine: str
    operator: str
    _depth: int

    # -- hooks ---------------------------------------------------------------------------------
    def _execute(self, sql: str, args: Sequence[Any] = ()) -> Any:
        raise NotImplementedError

    def _executemany(self, sql: str, rows: Iterable[Sequence[Any]]) -> None:
        raise NotImplementedError

    def _load(self, table: str, columns: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
        """Insert many rows of ``table`` (the back end's fastest way)."""
        marks = ",".join("?" * len(columns))
        self._executemany(f"INSERT INTO {table} ({', '.join(columns)}) VALUES ({marks})", rows)

    def _begin(self) -> None:
        raise NotImplementedError

    def _commit(self) -> None:
        raise NotImplementedError

    def _rollback(self) -> None:
        raise NotImplementedError

    def _failure(self, exc: BaseException) -> StoreError:
        raise NotImplementedError

    def _as_text(self, column: str) -> str:
        raise NotImplementedError

    # -- transactions --------------------------------------------------------------------------
    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        if self._depth:
            self._depth += 1
            try:
                yield
            finally:
                self._depth -= 1
            return
        try:
            self._begin()
        except self.errors as exc:
            raise self._failure(exc) from None
        self._depth = 1
        try:
            yield
            self._commit()
        except self.errors as exc:  # the COMMIT itself (a full disk, a lost connection)
            self._rollback()
            raise self._failure(exc) from None
        except BaseException:
            self._rollback()
            raise
        finally:
            self._depth = 0

    def __enter__(self) -> SQLStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _all(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        return [tuple(r) for r in self._execute(sql, args).fetchall()]

    def _one(self, sql: str, args: Sequence[Any] = ()) -> tuple[Any, ...] | None:
        row = self._execute(sql, args).fetchone()
        return None if row is None else tuple(row)

    # -- reports and their rows ----------------------------------------------------------------
    @guarded
    def add_report(
        self, data: bytes, name: str, format: str, table: pd.DataFrame, *, excluded: str | None = None
    ) -> tuple[str, bool]:
        if excluded is not None and excluded not in EXCLUDED_REASONS:
            raise ValueError(f"excluded must be None or one of {EXCLUDED_REASONS}, not {excluded!r}")
        sha = hashlib.sha256(data).hexdigest()
        cols = list(CANONICAL_COLUMNS)
        frame = table.reindex(columns=[*cols, "reference"])
        stamps = [str(t) for t in frame["timestamp"] if _cell(t, True) is not None]
        with self.transaction():
            inserted = self._one(
                "INSERT INTO report (sha256, name, format, size, imported_at, machine, rows, first_measured, "
                "last_measured, excluded) VALUES (?,?,?,?,?,?,?,?,?,?) ON CONFLICT (machine, sha256) DO NOTHING "
                "RETURNING id",
                (
                    sha,
                    name,
                    format,
                    len(data),
                    now(),
                    self.machine,
                    len(frame),
                    min(stamps, default=None),
                    max(stamps, default=None),
                    excluded,
                ),
            )
            if inserted is None:  # stored before (or by another process meanwhile, which committed)
                self._execute(
                    f"UPDATE report SET excluded = ? WHERE machine = ? AND sha256 = ? AND excluded {self.distinct} ?",
                    (excluded, self.machine, sha, excluded),
                )
                return sha, False
            flags = [int(str(v).strip().lower() in ("true", "1", "1.0")) for v in frame["reference"]]
            rows = [
                (inserted[0], i, *(_cell(v, c in _TEXT) for c, v in zip(cols, values, strict=True)), flag)
                for i, (values, flag) in enumerate(zip(frame[cols].itertuples(index=False), flags, strict=True))
            ]
            self._load("measurement", ["report_id", "row", *cols, "reference"], rows)
        return sha, True

    @guarded
    def report(self, sha256: str) -> ReportRecord | None:
        found = self._reports("AND sha256 = ?", (sha256,))
        return found[0] if found else None

    @guarded
    def reports(self) -> list[ReportRecord]:
        return self._reports("", ())

    def _reports(self, where: str, args: Sequence[Any]) -> list[ReportRecord]:
        rows = self._all(
            "SELECT sha256, name, format, size, rows, imported_at, machine, excluded FROM report "
            f"WHERE machine = ? {where} ORDER BY id",
            (self.machine, *args),
        )
        return [ReportRecord(*row) for row in rows]

    @guarded
    def measurements(self, sha256: str | None = None, *, include_excluded: bool = False) -> pd.DataFrame:
        cols = ", ".join(f"m.{c}" for c in CANONICAL_COLUMNS)
        args: tuple[str, ...] = (self.machine,)
        if sha256:
            where, args = "AND r.sha256 = ?", (self.machine, sha256)
        else:
            where = "" if include_excluded else "AND r.excluded IS NULL"
        cur = self._execute(
            f"SELECT {cols}, m.reference, r.sha256 FROM report r JOIN measurement m "
            f"ON m.report_id = r.id WHERE r.machine = ? {where} ORDER BY r.id, m.row",
            args,
        )
        frame = pd.DataFrame.from_records(cur.fetchall(), columns=[*CANONICAL_COLUMNS, "reference", "report_sha256"])
        for c in NUMERIC:
            frame[c] = pd.to_numeric(frame[c], errors="coerce").astype(float)
        frame["reference"] = frame["reference"].astype(bool)
        return frame

    # -- logs: corrections and temperatures ----------------------------------------------------
    @guarded
    def add_corrections(self, log: pd.DataFrame) -> int:
        frame = log.reindex(columns=list(CORRECTION_COLUMNS))
        rows = [
            (self.machine, str(t), str(r), _cell(d, False), str(e or "correction"))
            for t, r, d, e in frame.itertuples(index=False)
        ]
        return self._merge(
            "correction", ("machine", *CORRECTION_COLUMNS), ("machine", "timestamp", "register", "event"), rows
        )

    @guarded
    def corrections(self, event: str | None = None) -> pd.DataFrame:
        where, args = ("AND event = ?", (self.machine, event)) if event else ("", (self.machine,))
        rows = self._all(
            f"SELECT timestamp, register, delta, event FROM correction WHERE machine = ? {where} "
            "ORDER BY timestamp, id",
            args,
        )
        frame = pd.DataFrame.from_records(rows, columns=list(CORRECTION_COLUMNS))
        frame["delta"] = pd.to_numeric(frame["delta"], errors="coerce").astype(float)
        return frame

    @guarded
    def add_temperatures(self, log: pd.DataFrame) -> int:
        if "timestamp" not in log:
            raise StoreError("a temperature log needs a timestamp column", location=SourceLocation(self.location))
        long = log.melt(id_vars=["timestamp"], var_name="channel", value_name="value").dropna(subset=["value"])
        rows = [(self.machine, str(t), str(c), float(v)) for t, c, v in long.itertuples(index=False)]
        return self._merge(
            "temperature", ("machine", "timestamp", "channel", "value"), ("machine", "timestamp", "channel"), rows
        )

    @guarded
    def temperatures(self) -> pd.DataFrame:
        rows = self._all(
            "SELECT timestamp, channel, value FROM temperature WHERE machine = ? ORDER BY timestamp", (self.machine,)
        )
        if not rows:
            return pd.DataFrame(columns=["timestamp"])
        long = pd.DataFrame.from_records(rows, columns=["timestamp", "channel", "value"])
        wide = long.pivot(index="timestamp", columns="channel", values="value").reset_index()
        wide.columns.name = None
        return wide

    def _merge(self, table: str, columns: Sequence[str], keys: Sequence[str], rows: list[tuple[Any, ...]]) -> int:
        """Insert ``rows``; repeats of stored rows change nothing, contradictions are refused.

        Inserted first (``ON CONFLICT DO NOTHING`` waits for a concurrent writer of the same key),
        compared after: a row another process committed meanwhile is compared too.
        """
        values = [c for c in columns if c not in keys]
        cols, on = ", ".join(columns), " AND ".join(f"i.{k} = t.{k}" for k in keys)
        differ = " OR ".join(f"i.{v} {self.distinct} t.{v}" for v in values)
        key_cols = ", ".join(keys)
        with self.transaction():
            self._execute(f"CREATE TEMP TABLE IF NOT EXISTS incoming_{table} AS SELECT {cols} FROM {table} WHERE 1 = 0")
            self._execute(f"DELETE FROM incoming_{table}")
            self._load(f"incoming_{table}", columns, rows)
            twice = self._one(
                f"SELECT {key_cols} FROM incoming_{table} GROUP BY {key_cols} HAVING "
                + " OR ".join(f"count(DISTINCT {self._as_text(v)}) > 1" for v in values)
                + " LIMIT 1"
            )
            new = 0
            if twice is None:
                new = self._execute(
                    f"INSERT INTO {table} ({cols}) SELECT DISTINCT {cols} FROM incoming_{table} "
                    f"WHERE 1 = 1 ON CONFLICT ({key_cols}) DO NOTHING"
                ).rowcount
            clash = twice or self._one(
                f"SELECT {', '.join(f'i.{k}' for k in keys)} FROM incoming_{table} i "
                f"JOIN {table} t ON {on} WHERE {differ} LIMIT 1"
            )
            if clash:
                what = ", ".join(f"{k} {v}" for k, v in zip(keys, clash, strict=True) if k != "machine")
                raise StoreError(
                    f"{table} at {what} contradicts " + ("itself" if twice else "the stored one"),
                    location=SourceLocation(self.location),
                    hint="a stored row is never changed",
                )
            self._execute(f"DELETE FROM incoming_{table}")
        return int(new)

    # -- recommendations and their audit -------------------------------------------------------
    @guarded
    def add_recommendation(self, rec: Recommendation) -> int:
        a = audit_of(rec.inputs, rec.result)
        with self.transaction():
            name = a.report
            if not name and a.report_sha256:
                known = self._one(
                    "SELECT name FROM report WHERE machine = ? AND sha256 = ?", (self.machine, a.report_sha256)
                )
                name = str(known[0]) if known else ""
            row = self._one(
                "INSERT INTO recommendation (created_at, optimizer, inputs, result, machine, operator, report, "
                "report_sha256, part, verdict, rules, applied, exported_to, export_sha256) "
                "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?) RETURNING id",
                (
                    rec.created_at or now(),
                    rec.optimizer,
                    json.dumps(rec.inputs, sort_keys=True),
                    json.dumps(rec.result, sort_keys=True),
                    self.machine,
                    self.operator,
                    name,
                    a.report_sha256,
                    a.part,
                    a.verdict,
                    a.rules,
                    int(a.applied),
                    a.exported_to,
                    a.export_sha256,
                ),
            )
            assert row is not None
            if a.deltas:
                self._load(
                    "recommendation_delta",
                    ("recommendation_id", "register", "delta"),
                    [(row[0], r, d) for r, d in a.deltas],
                )
        return int(row[0])

    @guarded
    def recommendations(self) -> list[Recommendation]:
        rows = self._all(
            "SELECT optimizer, inputs, result, created_at, machine, operator FROM recommendation "
            "WHERE machine = ? ORDER BY id",
            (self.machine,),
        )
        return [Recommendation(o, json.loads(i), json.loads(r), c, m, op) for o, i, r, c, m, op in rows]

    @guarded
    def audit(self, *, every_machine: bool = False) -> pd.DataFrame:
        where, args = ("", ()) if every_machine else ("WHERE r.machine = ?", (self.machine,))
        rows = self._all(
            "SELECT r.created_at, r.machine, r.operator, r.report, r.report_sha256, r.part, "
            "r.optimizer, r.verdict, d.register, d.delta, r.applied, r.exported_to FROM recommendation r "
            f"LEFT JOIN recommendation_delta d ON d.recommendation_id = r.id {where} "
            "ORDER BY r.id, d.register",
            args,
        )
        frame = pd.DataFrame.from_records(rows, columns=list(AUDIT_COLUMNS))
        frame["delta"] = pd.to_numeric(frame["delta"], errors="coerce").astype(float)
        frame["applied"] = frame["applied"].astype(bool)
        return frame

    # -- the plant ----------------------------------------------------------------------------
    @guarded
    def machines(self) -> list[MachineSummary]:
        found: dict[str, dict[str, Any]] = {}

        def put(rows: list[tuple[Any, ...]], *names: str) -> None:
            for machine, *values in rows:
                found.setdefault(str(machine), {}).update(zip(names, values, strict=True))

        put(
            self._all(
                "SELECT machine, count(*), sum(rows), min(first_measured), max(last_measured), "
                "max(imported_at) FROM report GROUP BY machine"
            ),
            "reports",
            "rows",
            "first_measured",
            "last_measured",
            "last_import",
        )
        for machine, event, n in self._all("SELECT machine, event, count(*) FROM correction GROUP BY machine, event"):
            put([(machine, n)], "tool_changes" if event == "tool_change" else "corrections")
        put(
            self._all(
                "SELECT machine, count(DISTINCT timestamp), count(DISTINCT channel) FROM temperature GROUP BY machine"
            ),
            "temperature_samples",
            "temperature_channels",
        )
        put(
            self._all("SELECT machine, count(*), max(created_at) FROM recommendation GROUP BY machine"),
            "recommendations",
            "last_recommendation",
        )
        counts: dict[str, dict[str, Any]] = {
            m: {k: (v if k.startswith(("first", "last")) else int(v or 0)) for k, v in found[m].items()} for m in found
        }
        return [MachineSummary(m, **counts[m]) for m in sorted(counts)]

    # -- a whole copy (history migrate) -------------------------------------------------------
    def dump(self, table: str) -> Iterator[tuple[Any, ...]]:
        """Every row of ``table`` (:data:`setupfix.store.audit.TABLES`) in its columns' order.

        A failure while the rows are read (a damaged page, a text that is not UTF-8) is a
        :class:`StoreError` too, wherever the caller iterates.
        """
        _, columns, order = next(t for t in TABLES if t[0] == table)
        try:
            cur = self._execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY {order}")
            while batch := cur.fetchmany(10_000):
                yield from (tuple(r) for r in batch)
        except self.errors as exc:
            raise self._failure(exc) from None

    @guarded
    def count(self, table: str) -> int:
        row = self._one(f"SELECT count(*) FROM {table}")
        return int(row[0]) if row else 0

    @guarded
    def restore(self, table: str, rows: Iterable[Sequence[Any]]) -> None:
        """Insert rows :meth:`dump` gave, as they are (ids included), in one transaction."""
        _, columns, _ = next(t for t in TABLES if t[0] == table)
        with self.transaction():
            self._restore(table, columns, rows)

    def _restore(self, table: str, columns: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
        self._load(table, columns, rows)
