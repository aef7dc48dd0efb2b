"""The audit trail of a recommendation, and the copy of a whole store into another.

Every recommendation is stored with its JSON (inputs and result, as the doors write them)
and, beside it, the audit columns read from that JSON once, when it is stored: report
name and SHA-256, part, verdict, rules, whether it was applied and to which program
(file name and SHA-256 of the text), and one row per register component with its delta.
The machine and the operator come from the store handle that writes it
(:func:`setupfix.store.open_store`).

Where the doors put those facts (``inputs``/``result`` keys):

* report SHA-256: ``inputs["report_sha256"]``, else ``inputs["report"]`` when it is a hash
  (``batch`` keeps the content hash there; the name is then the stored report's);
* report name: ``inputs["report"]`` when it is not a hash, else ``result["report"]``;
* part: ``inputs["part"]``, else ``result["part"]``; verdict and rules: ``result``;
* deltas: ``result["corrections"]`` (``correct``, ``batch``), else ``result["next_correction"]``
  (``diagnose``), register component → delta;
* applied and export: ``inputs["applied"]`` and ``inputs["export"]`` (``target``, ``sha256``).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from setupfix.store.link_audit import LINK_TABLES

__all__ = ["Audit", "audit_of", "AUDIT_COLUMNS", "TABLES"]

#: Columns of ``history export recommendations``: one row per register component of each recommendation.
AUDIT_COLUMNS = (
    "created_at",
    "machine",
    "operator",
    "report",
    "report_sha256",
    "part",
    "optimizer",
    "verdict",
    "register",
    "delta",
    "applied",
    "exported_to",
)

#: Every table of a store with its columns, in the order a copy fills them (parents before children).
TABLES: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "report",
        (
            "id",
            "sha256",
            "name",
            "format",
            "size",
            "imported_at",
            "machine",
            "rows",
            "first_measured",
            "last_measured",
            "excluded",
        ),
        "id",
    ),
    (
        "measurement",
        (
            "report_id",
            "row",
            "characteristic",
            "nominal",
            "actual",
            "deviation",
            "lower",
            "upper",
            "unit",
            "part",
            "report",
            "timestamp",
            "station",
            "x",
            "y",
            "z",
            "status",
            "source",
            "reference",
        ),
        "report_id, row",
    ),
    ("correction", ("id", "machine", "timestamp", "register", "delta", "event"), "id"),
    ("temperature", ("machine", "timestamp", "channel", "value"), "machine, timestamp, channel"),
    (
        "recommendation",
        (
            "id",
            "created_at",
            "optimizer",
            "inputs",
            "result",
            "machine",
            "operator",
            "report",
            "report_sha256",
            "part",
            "verdict",
            "rules",
            "applied",
            "exported_to",
            "export_sha256",
        ),
        "id",
    ),
    ("recommendation_delta", ("recommendation_id", "register", "delta"), "recommendation_id, register"),
    (
        "batch_claim",
        ("machine", "report_sha256", "done", "owner", "host", "pid", "started", "claimed_at"),
        "machine, report_sha256",
    ),
    *LINK_TABLES,  # the machine link's attempts and their components (schema 6)
)

_SHA256 = re.compile(r"[0-9a-f]{64}")


@dataclass(frozen=True)
class Audit:
    """The audit columns of one recommendation (read from its inputs and result)."""

    report: str
    report_sha256: str
    part: str
    verdict: str
    rules: str
    applied: bool
    exported_to: str
    export_sha256: str
    deltas: tuple[tuple[str, float | None], ...]


def _text(value: object) -> str:
    return "" if value is None else str(value)


def _delta(value: object) -> float | None:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _verdict(result: Mapping[str, Any]) -> str:
    """The verdict column: a stopped solve is never a plain verdict (``not solved (…)``, ``apply (stopped: …)``)."""
    from setupfix.correction.recommend import verdict_text  # lazily: the store opens without the solver

    verdict = _text(result.get("verdict"))
    stopped = result.get("stopped")
    where = (
        f"{_text(stopped.get('reason'))} in the {_text(stopped.get('stage'))} stage"
        if isinstance(stopped, Mapping) and stopped.get("reason")
        else ""
    )
    return verdict_text(verdict, result.get("solved", True) is not False, where) if verdict else verdict


def audit_of(inputs: Mapping[str, Any], result: Mapping[str, Any]) -> Audit:
    """The audit columns of a recommendation with these ``inputs`` and ``result`` (module docstring)."""
    given = _text(inputs.get("report"))
    sha = _text(inputs.get("report_sha256")) or (given if _SHA256.fullmatch(given) else "")
    name = given if given and given != sha else _text(result.get("report"))
    deltas = result.get("corrections")
    if not isinstance(deltas, Mapping):
        deltas = result.get("next_correction")
    pairs = tuple(sorted((str(k), _delta(v)) for k, v in deltas.items())) if isinstance(deltas, Mapping) else ()
    export = inputs.get("export")
    export = export if isinstance(export, Mapping) else {}
    rules = result.get("rules")
    return Audit(
        report=name,
        report_sha256=sha,
        part=_text(inputs.get("part") or result.get("part")),
        verdict=_verdict(result),
        rules=json.dumps(rules if isinstance(rules, list) else [], sort_keys=True),
        applied=bool(inputs.get("applied")),
        exported_to=_text(export.get("target")),
        export_sha256=_text(export.get("sha256")),
        deltas=pairs,
    )
