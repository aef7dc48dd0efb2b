"""The plan ``machine write`` writes: a plan file (``correct --link --json``) or a cycle corrected now."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from setupfix.core.errors import ParseError, SourceLocation
from setupfix.links.mapping import model_components
from setupfix.links.snapshot import ControlSnapshot
from setupfix.model import ProcessModel
from setupfix.usecases.requests import CurrentOffsets, CycleCorrection

__all__ = ["Plan", "plan_of", "load_plan"]


# -- the plan ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Plan:
    """A decision to write: the corrections (model ID → change, model unit), its verdict, and the
    control's values it was made with (None when it was made without a link)."""

    source: str
    sha256: str
    verdict: str
    solved: bool
    corrections: tuple[tuple[str, float], ...]
    made_with: ControlSnapshot | None
    draft: bool = False
    alarm: str = ""

    @property
    def refusal(self) -> str | None:
        """Why this plan is never written, or None (``apply`` verdict of a finished solve, not a draft)."""
        if self.draft:
            return "the model is a draft (remove [process] draft once edited): nothing is written"
        if not self.solved:
            return "the solve was stopped with nothing proven to recommend: nothing is written"
        if self.verdict != "apply":
            return f"the verdict is {self.verdict!r}, not 'apply': nothing is written"
        return None


def _sha256_of(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def plan_of(cycle: CycleCorrection, current: CurrentOffsets | None, source: str = "") -> Plan:
    """The plan of one corrected cycle (``machine write REPORT``); its hash is that of its JSON."""
    from setupfix.usecases.contract import cycle_json

    obj = cycle_json(cycle)
    snapshot = current.snapshot if current is not None else None
    if snapshot is not None:
        obj["link"] = snapshot.to_json()
    return Plan(
        source=source or cycle.part.report,
        sha256=_sha256_of(obj),
        verdict=cycle.verdict,
        solved=cycle.solved,
        corrections=tuple(cycle.corrections.items()),
        made_with=snapshot,
        draft=cycle.model.draft,
        alarm=cycle.recommendation.alarm or "",
    )


def load_plan(path: str | Path, model: ProcessModel) -> Plan:
    """A plan file: the ``correct --json`` object of one part, made with ``--link``.

    Raises
    ------
    ParseError
        Naming the file and key: not JSON, several parts (make it with ``--part``), no verdict,
        corrections that are not the model's registers, no ``"link"`` values (made without ``--link``).
    """
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ParseError(f"cannot read the plan: {exc.strerror or exc}", location=SourceLocation(name)) from None
    try:
        obj = json.loads(data)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ParseError(f"not a JSON plan (correct --json): {exc}", location=SourceLocation(name)) from None
    if isinstance(obj, dict) and "parts" in obj:
        parts = obj["parts"]
        if isinstance(parts, list) and len(parts) == 1:
            obj = {**parts[0], **({"link": obj["link"]} if "link" in obj else {})}
        else:
            raise ParseError(
                f"the plan holds {len(parts) if isinstance(parts, list) else 'several'} parts: one part is written",
                location=SourceLocation(name, key="parts"),
                hint="make the plan with correct --part ID",
            )
    if not isinstance(obj, dict):
        raise ParseError("expected the JSON object of correct --json", location=SourceLocation(name))
    verdict = obj.get("verdict")
    if verdict not in ("apply", "hold", "reject"):
        raise ParseError(
            f"expected a verdict apply, hold or reject, found {verdict!r}", location=SourceLocation(name, key="verdict")
        )
    corrections = obj.get("corrections")
    if not isinstance(corrections, dict):
        raise ParseError("expected the corrections by register", location=SourceLocation(name, key="corrections"))
    wanted = set(model_components(model))
    given: dict[str, float] = {}
    for key, value in corrections.items():
        if key not in wanted:
            raise ParseError(
                f"register {key!r} is not a correctable register of the model {model.source}",
                location=SourceLocation(name, key=f"corrections.{key}"),
            )
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ParseError(
                f"expected a finite number, found {value!r}", location=SourceLocation(name, key=f"corrections.{key}")
            )
        given[key] = float(value)
    missing = sorted(wanted - set(given))
    if missing:
        raise ParseError(
            f"no correction for {', '.join(missing)} of the model", location=SourceLocation(name, key="corrections")
        )
    if "link" not in obj:
        raise ParseError(
            "the plan records no values read from the control: nothing can prove the table unchanged",
            location=SourceLocation(name, key="link"),
            hint="make the plan with correct --link LINK --json",
        )
    snapshot = ControlSnapshot.from_json(obj["link"], SourceLocation(name))
    solved = obj.get("solved", True)
    return Plan(
        source=name,
        sha256=hashlib.sha256(data).hexdigest(),
        verdict=str(verdict),
        solved=bool(solved),
        corrections=tuple((rid, given[rid]) for rid in model_components(model)),
        made_with=snapshot,
        draft=model.draft,
        alarm=str(obj.get("alarm") or ""),
    )
