"""Batch claims on both back ends: a report is corrected by one run at a time, and once.

A claim is one machine's (the store handle's): the same report given for two machines is
claimed, processed and skipped for each on its own.

See :meth:`setupfix.store.Store.claim_reports`.  A claim row is created first (``ON CONFLICT
DO NOTHING``) and then read with the back end's row lock (PostgreSQL: ``FOR UPDATE``; SQLite's
``BEGIN IMMEDIATE`` already serialises writers), keys in sorted order, so two batches claiming
overlapping reports never wait for each other in a circle and never both take one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from datetime import UTC, datetime

from setupfix.store import ALREADY_PROCESSED, HELD_ELSEWHERE, Claimant
from setupfix.store.sql import SQLStore, guarded, now

__all__ = ["ClaimingStore"]


def age_s(at: str | None) -> float:
    """Seconds since the ISO time ``at`` (infinite when it cannot be read)."""
    try:
        then = datetime.fromisoformat(str(at))
    except ValueError:
        return math.inf
    if then.tzinfo is None:
        then = then.replace(tzinfo=UTC)
    return (datetime.now(UTC) - then).total_seconds()


class ClaimingStore(SQLStore):
    """:class:`SQLStore` with the batch claims (the back ends derive from this)."""

    # -- batch claims --------------------------------------------------------------------------
    @guarded
    def claim_reports(self, keys: Sequence[str], claimant: Claimant, *, again: bool = False) -> dict[str, str]:
        refused: dict[str, str] = {}
        wanted = sorted(dict.fromkeys(keys))
        with self.transaction():
            self._executemany(
                "INSERT INTO batch_claim (machine, report_sha256, done) VALUES (?, ?, 0) "
                "ON CONFLICT (machine, report_sha256) DO NOTHING",
                [(self.machine, k) for k in wanted],
            )
            for key in wanted:
                row = self._one(
                    "SELECT done, owner, host, pid, started, claimed_at FROM batch_claim "
                    f"WHERE machine = ? AND report_sha256 = ?{self.lock}",
                    (self.machine, key),
                )
                if row is not None:
                    done, owner, host, pid, started, at = row
                    if owner is not None and owner != claimant.token:
                        holder = Claimant(owner, str(host or ""), int(pid or 0), str(started or ""))
                        if not holder.gone(age_s(at)):
                            refused[key] = f"{HELD_ELSEWHERE} ({holder}, since {at}): left to it"
                            continue
                    if done and not again and owner != claimant.token:
                        refused[key] = ALREADY_PROCESSED
                        continue
                self._execute(
                    "UPDATE batch_claim SET owner = ?, host = ?, pid = ?, started = ?, claimed_at = ? "
                    "WHERE machine = ? AND report_sha256 = ?",
                    (claimant.token, claimant.host, claimant.pid, claimant.started, now(), self.machine, key),
                )
            self._executemany(
                "DELETE FROM batch_claim WHERE machine = ? AND report_sha256 = ? AND owner IS NULL AND done = 0",
                [(self.machine, k) for k in wanted],
            )
        return {k: refused[k] for k in dict.fromkeys(keys) if k in refused}

    @guarded
    def finish_claims(self, keys: Sequence[str], claimant: Claimant) -> None:
        with self.transaction():
            self._executemany(
                "UPDATE batch_claim SET done = 1, owner = NULL, host = NULL, pid = NULL, "
                "started = NULL, claimed_at = NULL WHERE machine = ? AND report_sha256 = ? AND owner = ?",
                [(self.machine, k, claimant.token) for k in sorted(dict.fromkeys(keys))],
            )

    @guarded
    def release_claims(self, claimant: Claimant) -> None:
        with self.transaction():
            held = self._all(
                "SELECT machine, report_sha256 FROM batch_claim WHERE owner = ? ORDER BY machine, report_sha256",
                (claimant.token,),
            )
            self._executemany(
                "UPDATE batch_claim SET owner = NULL, host = NULL, pid = NULL, started = NULL, "
                "claimed_at = NULL WHERE machine = ? AND report_sha256 = ? AND owner = ?",
                [(m, k, claimant.token) for m, k in held],
            )
            self._executemany(
                "DELETE FROM batch_claim WHERE machine = ? AND report_sha256 = ? AND owner IS NULL AND done = 0", held
            )
