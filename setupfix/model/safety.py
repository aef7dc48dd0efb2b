"""Safety settings of a process model: the ``[safety]`` table and per-register extras.

Plain data and its validation; the rules themselves are pure functions in
:mod:`setupfix.safety`.  Every length is in the model unit.  Defaults (documented in
the README, section *Safety rules*):

=====================  =========================  =======================================
key                    default                    meaning
=====================  =========================  =======================================
``dead_band``          2 × resolution             hold when every change is within it
``gain``               1.0                        feedback fraction of the optimum applied
``reject_band``        each tolerance's width     reject beyond a limit by more than this
``cumulative_limit``   off                        bound on |current + change| (wear)
``uncertainty``        0 (no guard band)          expanded uncertainty U of every dimension
``guard_band``         1.0                        fraction of U the limits shrink by
``ewma``               1.0 (no smoothing)         λ of the smoothing over reports
=====================  =========================  =======================================

Per register (``[wks.ID]`` / ``[tools.ID]``): ``cost`` (> 0, least-norm weight),
``offset`` (``"wear"`` or ``"geometry"``; default wear for a tool, geometry for a WKS),
``number`` and ``edge`` (controller slot where the register name does not give it),
``dead_band``, ``gain``, ``cumulative_limit``.  Per dimension: ``uncertainty`` and
``reject_band``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

__all__ = ["OffsetType", "RegisterPolicy", "SafetySettings", "SAFETY_KEYS", "REGISTER_KEYS", "DIMENSION_KEYS",
           "safety_from_doc"]

OffsetType = Literal["wear", "geometry"]

#: Keys of the ``[safety]`` table.
SAFETY_KEYS = frozenset({"dead_band", "gain", "reject_band", "cumulative_limit", "uncertainty", "guard_band",
                         "ewma"})
#: Extra keys a ``[wks.ID]`` or ``[tools.ID]`` table may hold.
REGISTER_KEYS = frozenset({"cost", "offset", "number", "edge", "dead_band", "gain", "cumulative_limit"})
#: Extra keys a ``[dimensions.ID]`` table may hold.
DIMENSION_KEYS = frozenset({"uncertainty", "reject_band"})


@dataclass(frozen=True, slots=True)
class RegisterPolicy:
    """Per-register preferences; ``None`` means the model-wide setting."""

    cost: float = 1.0
    offset: OffsetType | None = None
    number: int | None = None
    edge: int | None = None
    dead_band: float | None = None
    gain: float | None = None
    cumulative_limit: float | None = None


@dataclass(frozen=True, slots=True)
class SafetySettings:
    """The model's safety rules (``[safety]`` plus per-register and per-dimension extras)."""

    dead_band: float | None = None
    gain: float = 1.0
    reject_band: float | None = None
    cumulative_limit: float | None = None
    uncertainty: float = 0.0
    guard_band: float = 1.0
    ewma: float = 1.0
    registers: Mapping[str, RegisterPolicy] = field(default_factory=dict)
    dimension_uncertainty: Mapping[str, float] = field(default_factory=dict)
    dimension_reject_band: Mapping[str, float] = field(default_factory=dict)

    def register(self, rid: str) -> RegisterPolicy:
        return self.registers.get(rid, _DEFAULT_POLICY)


_DEFAULT_POLICY = RegisterPolicy()

AddProblem = Callable[[str, str], None]


def _num(add: AddProblem, key: str, value: Any, low: float, high: float = math.inf, *,
         open_low: bool = False) -> float | None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and (value > low or (not open_low and value == low)) and value <= high:
        return float(value)
    bracket = "(" if open_low else "["
    upper = "∞)" if high == math.inf else f"{high:g}]"
    add(key, f"expected a number in {bracket}{low:g}, {upper}, found {value!r}")
    return None


def _slot(add: AddProblem, key: str, value: Any) -> int | None:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 99999:
        return value
    add(key, f"expected a whole number in [0, 99999], found {value!r}")
    return None


def _register_policy(add: AddProblem, key: str, table: Mapping[str, Any]) -> RegisterPolicy | None:
    if not any(k in table for k in REGISTER_KEYS):
        return None
    offset = table.get("offset")
    if offset is not None and offset not in ("wear", "geometry"):
        add(f"{key}.offset", f'expected "wear" or "geometry", found {offset!r}')
        offset = None
    cost = _num(add, f"{key}.cost", table["cost"], 0.0, open_low=True) if "cost" in table else 1.0
    return RegisterPolicy(
        cost=cost if cost is not None else 1.0,
        offset=offset,
        number=_slot(add, f"{key}.number", table["number"]) if "number" in table else None,
        edge=_slot(add, f"{key}.edge", table["edge"]) if "edge" in table else None,
        dead_band=_num(add, f"{key}.dead_band", table["dead_band"], 0.0) if "dead_band" in table else None,
        gain=_num(add, f"{key}.gain", table["gain"], 0.0, 1.0, open_low=True) if "gain" in table else None,
        cumulative_limit=(_num(add, f"{key}.cumulative_limit", table["cumulative_limit"], 0.0, open_low=True)
                          if "cumulative_limit" in table else None),
    )


def safety_from_doc(doc: Mapping[str, Any], add: AddProblem) -> SafetySettings:
    """Read the safety settings of a parsed model document.

    ``add(key_path, message)`` collects each problem (the loader's problem list),
    so a bad value is reported with the model's other problems, never raised alone.
    Unknown keys of ``[safety]`` are reported the same way.
    """
    raw = doc.get("safety", {})
    if not isinstance(raw, Mapping):
        add("safety", f"expected a table, found {type(raw).__name__}")
        raw = {}
    for name in raw:
        if name not in SAFETY_KEYS:
            add(f"safety.{name}", f"unknown key (expected one of: {', '.join(sorted(SAFETY_KEYS))})")

    def get(name: str, low: float, high: float = math.inf, *, open_low: bool = False) -> float | None:
        return _num(add, f"safety.{name}", raw[name], low, high, open_low=open_low) if name in raw else None

    registers: dict[str, RegisterPolicy] = {}
    for section in ("wks", "tools"):
        tables = doc.get(section, {})
        for rid, table in (tables.items() if isinstance(tables, Mapping) else ()):
            if isinstance(table, Mapping):
                policy = _register_policy(add, f"{section}.{rid}", table)
                if policy is not None:
                    registers[rid] = policy
    uncertainty: dict[str, float] = {}
    reject: dict[str, float] = {}
    dims = doc.get("dimensions", {})
    for did, table in (dims.items() if isinstance(dims, Mapping) else ()):
        if not isinstance(table, Mapping):
            continue
        if "uncertainty" in table:
            u = _num(add, f"dimensions.{did}.uncertainty", table["uncertainty"], 0.0)
            if u is not None:
                uncertainty[did] = u
        if "reject_band" in table:
            r = _num(add, f"dimensions.{did}.reject_band", table["reject_band"], 0.0, open_low=True)
            if r is not None:
                reject[did] = r
    gain = get("gain", 0.0, 1.0, open_low=True)
    uncertainty_all = get("uncertainty", 0.0)
    guard = get("guard_band", 0.0, 1.0)
    ewma = get("ewma", 0.0, 1.0, open_low=True)
    return SafetySettings(
        dead_band=get("dead_band", 0.0),
        gain=1.0 if gain is None else gain,
        reject_band=get("reject_band", 0.0, open_low=True),
        cumulative_limit=get("cumulative_limit", 0.0, open_low=True),
        uncertainty=0.0 if uncertainty_all is None else uncertainty_all,
        guard_band=1.0 if guard is None else guard,
        ewma=1.0 if ewma is None else ewma,
        registers=registers,
        dimension_uncertainty=uncertainty,
        dimension_reject_band=reject,
    )
