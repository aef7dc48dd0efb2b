"""The audit of the machine link: every attempt to write a control's offsets, and what each component did.

``machine write`` records one :class:`LinkAttempt` per run whether it wrote or not (a dry run,
a refusal, an unreachable control, a roll-back): the machine and operator of the store handle,
the time, the link (endpoint and file, never a credential), the plan's SHA-256, the outcome
and its message, and per register component the value before, the change, the value written,
the value read back, the value read back after a roll-back and the component's own outcome
(``../shared/spec/machine-link.md``, step 5).  Values are in the control's unit (``unit``).

:class:`LinkAuditStore` is the part of :class:`setupfix.store.sql.SQLStore` that keeps them
(tables ``link_attempt`` and ``link_component``, schema version 6 of both back ends).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from setupfix.core.errors import StoreError

__all__ = ["LinkAttempt", "LinkComponentRecord", "LinkAuditStore", "ATTEMPT_OUTCOMES", "LINK_TABLES"]

#: ``outcome`` of an attempt (the JSON's of ``machine write``).
ATTEMPT_OUTCOMES = ("dry_run", "applied", "refused", "rolled_back", "unconfirmed", "unreachable")

#: The two tables with their columns, as :data:`setupfix.store.audit.TABLES` lists a table (for a copy).
LINK_TABLES: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "link_attempt",
        ("id", "created_at", "machine", "operator", "link", "plan_sha256", "outcome", "message", "unit"),
        "id",
    ),
    (
        "link_component",
        (
            "attempt_id",
            "position",
            "register",
            "axis",
            "before",
            "change",
            "written",
            "read_back",
            "restored",
            "outcome",
        ),
        "attempt_id, position",
    ),
)


@dataclass(frozen=True)
class LinkComponentRecord:
    """One register component of an attempt (control unit; None where the step was not reached).

    ``outcome``: ``planned`` (dry run, refusal), ``confirmed`` (written and read back within half
    an increment), ``rolled_back`` (restored to ``before``), ``not_restored`` (the roll-back did not
    hold: check the control) or ``unknown`` (the control could not be read).
    """

    register: str
    axis: str
    before: float | None
    change: float | None
    written: float | None
    read_back: float | None
    restored: float | None
    outcome: str


@dataclass(frozen=True)
class LinkAttempt:
    """One ``machine write`` run as the audit keeps it (``machine``/``operator``: the store handle's)."""

    link: str
    plan_sha256: str
    outcome: str
    message: str
    unit: str
    components: tuple[LinkComponentRecord, ...]
    created_at: str = ""
    machine: str = ""
    operator: str = ""

    def __post_init__(self) -> None:
        if self.outcome not in ATTEMPT_OUTCOMES:
            raise ValueError(f"unknown outcome {self.outcome!r}")


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


class LinkAuditStore:
    """The link audit's queries; mixed into :class:`~setupfix.store.sql.SQLStore` (which gives the hooks)."""

    errors: tuple[type[BaseException], ...]
    machine: str
    operator: str

    # hooks SQLStore implements (declared here for the type checker)
    def _one(self, sql: str, args: Sequence[Any] = ()) -> tuple[Any, ...] | None:
        raise NotImplementedError

    def _all(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        raise NotImplementedError

    def _load(self, table: str, columns: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
        raise NotImplementedError

    def _failure(self, exc: BaseException) -> StoreError:
        raise NotImplementedError

    def transaction(self) -> contextlib.AbstractContextManager[None]:
        raise NotImplementedError

    @contextlib.contextmanager
    def _named(self) -> Iterator[None]:
        try:
            yield
        except self.errors as exc:
            raise self._failure(exc) from None

    def add_link_attempt(self, attempt: LinkAttempt) -> int:
        """Record one attempt with its components in one transaction; its id."""
        with self._named(), self.transaction():
            row = self._one(
                "INSERT INTO link_attempt (created_at, machine, operator, link, plan_sha256, outcome, message, unit) "
                "VALUES (?,?,?,?,?,?,?,?) RETURNING id",
                (
                    attempt.created_at or _now(),
                    self.machine,
                    self.operator,
                    attempt.link,
                    attempt.plan_sha256,
                    attempt.outcome,
                    attempt.message,
                    attempt.unit,
                ),
            )
            assert row is not None
            _, columns, _ = LINK_TABLES[1]
            self._load(
                "link_component",
                columns,
                [
                    (row[0], i, c.register, c.axis, c.before, c.change, c.written, c.read_back, c.restored, c.outcome)
                    for i, c in enumerate(attempt.components)
                ],
            )
        return int(row[0])

    def link_attempts(self, *, every_machine: bool = False) -> list[LinkAttempt]:
        """The attempts in the order they were made (this handle's machine unless ``every_machine``)."""
        where, args = ("", ()) if every_machine else ("WHERE machine = ?", (self.machine,))
        with self._named():
            heads = self._all(
                "SELECT id, created_at, machine, operator, link, plan_sha256, outcome, message, unit "
                f"FROM link_attempt {where} ORDER BY id",
                args,
            )
            rows = self._all(
                "SELECT attempt_id, register, axis, before, change, written, read_back, restored, outcome "
                "FROM link_component ORDER BY attempt_id, position"
            )
        parts: dict[int, list[LinkComponentRecord]] = {}
        for aid, *rest in rows:
            reg, axis, before, change, written, read_back, restored, outcome = rest
            parts.setdefault(int(aid), []).append(
                LinkComponentRecord(
                    str(reg),
                    str(axis),
                    _num(before),
                    _num(change),
                    _num(written),
                    _num(read_back),
                    _num(restored),
                    str(outcome),
                )
            )
        return [
            LinkAttempt(
                link=str(link),
                plan_sha256=str(sha),
                outcome=str(outcome),
                message=str(message),
                unit=str(unit),
                components=tuple(parts.get(int(aid), ())),
                created_at=str(created),
                machine=str(machine),
                operator=str(operator),
            )
            for aid, created, machine, operator, link, sha, outcome, message, unit in heads
        ]


def _num(value: Any) -> float | None:
    return None if value is None else float(value)
