"""The ``correct --json`` object of ``../shared/spec/cli-json.md``: one builder for every door.

One builder for the contract, so ``correct --json``, ``batch``, the TUI's export and the stored
recommendation hold the same keys with the same meaning.  Typed notes
(:class:`~setupfix.core.errors.Note`) become text lines here and in :mod:`setupfix.views.present`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from setupfix.core.errors import Note
from setupfix.correction.numbers import unsigned_zero
from setupfix.correction.safety import STOPPED
from setupfix.usecases.requests import CycleCorrection

__all__ = ["JSON_DIGITS", "cycle_json", "outcome_json", "note_lines", "one_line"]

#: Digits of the lengths in the JSON output.
JSON_DIGITS = 9


def one_line(text: str) -> str:
    """Free text (a dimension's name) for one table cell: control characters shown as "?"."""
    return text if text.isprintable() else "".join(c if c.isprintable() else "?" for c in text)


def note_lines(notes: Iterable[Note]) -> list[str]:
    """Typed notes as one line of text each (``file: [place]: message``; control characters of names as "?")."""
    return [one_line(str(n)) for n in notes]


def cycle_json(pc: CycleCorrection) -> dict[str, Any]:
    """The ``correct --json`` object of ``../shared/spec/cli-json.md`` (plus extra keys) for one cycle."""
    digits = JSON_DIGITS
    r = pc.result
    names = {d.id: d.name for d in pc.model.dimensions}
    rec = pc.recommendation
    return (
        {
            "part": pc.part.part,
            "report": pc.part.report,
            "verdict": rec.verdict,
            "alarm": rec.alarm or None,
            "optimizer": r.optimizer,
            "status": r.status,
            "solved": rec.solved,
            "stopped": r.stopped.to_json() if r.stopped is not None and r.status in STOPPED else None,
            "norm_ratio_max": finite_or_none(r.norm_ratio_max),
            # f1 over every dimension (cli-json.md); the triage's kept set has its own keys
            "margin_before": unsigned_zero(pc.margin_all_before, digits),
            "margin_after": unsigned_zero(pc.margin_all_after, digits),
            "bonus": unsigned_zero(pc.margin_all_after - pc.margin_all_before, digits),
            # None when the triage kept no dimension (no budget: JSON has no infinity)
            "margin_kept_before": unsigned_zero(pc.margin_before, digits) if math.isfinite(pc.margin_before) else None,
            "margin_kept_after": unsigned_zero(pc.margin_after, digits) if math.isfinite(pc.margin_after) else None,
            "norm": unsigned_zero(pc.norm, digits),
            "bound": None if r.bound is None else unsigned_zero(r.bound, digits),
            "in_tolerance": pc.margin_after >= 0 and not pc.given_up,
            "message": r.message,
            "corrections": {k: unsigned_zero(v, digits) for k, v in pc.corrections.items()},
            "registers": [{**row, "delta": unsigned_zero(row["delta"], digits)} for row in pc.register_rows()],
            "binding": [names[b] for b in pc.binding],
            "given_up": [names[b] for b in pc.given_up],
            "at_limit": list(rec.at_limit),
            "rules": [e.to_json() for e in pc.rules],
            "dimensions": [
                {
                    k: (
                        unsigned_zero(v, digits)
                        if isinstance(v, float) and np.isfinite(v)
                        else (None if isinstance(v, float) else v)
                    )
                    for k, v in row.items()
                }
                for row in pc.dimension_rows()
            ],
            "absent": list(pc.part.absent),
            "unmatched": list(pc.part.unmatched),
            "suggestions": {name: list(near) for name, near in pc.part.suggestions.items()},
            "warnings": note_lines(pc.notes),
            "evaluations": r.evaluations,
            "seconds": round(r.seconds, 6),
        }
        | ({"thermal": pc.thermal.to_json()} if pc.thermal is not None else {})
        | ({"zone_polygon_error": pc.problem.polygon} if pc.problem.circles is not None else {})
    )


def finite_or_none(value: object) -> float | None:
    return unsigned_zero(float(value), 6) if isinstance(value, float) and math.isfinite(value) else None


def outcome_json(cycles: Iterable[CycleCorrection]) -> dict[str, Any]:
    """``correct --json``: one cycle's object, or ``{"parts": [...]}`` for several."""
    objs = [cycle_json(c) for c in cycles]
    return objs[0] if len(objs) == 1 else {"parts": objs}
