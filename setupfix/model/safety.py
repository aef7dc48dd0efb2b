"""Safety settings of a process model: the ``[safety]`` table and per-register extras.

Plain data and its validation; the rules themselves are pure functions in
:mod:`setupfix.correction.safety`.  Every length is in the model unit.  Defaults (documented in
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
``dead_band``, ``gain``, ``cumulative_limit``.  Per dimension
(``[safety.dimensions.ID]``): ``uncertainty`` and ``reject_band``.

The loader calls :func:`parse_safety` and :func:`parse_register_policy` directly; the
results are typed fields of the model (``ProcessModel.safety``, ``Register.policy``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from setupfix.model.process import Dimension

__all__ = [
    "OffsetType",
    "RegisterPolicy",
    "SafetySettings",
    "SAFETY_KEYS",
    "REGISTER_KEYS",
    "DIMENSION_KEYS",
    "parse_safety",
    "parse_register_policy",
    "guard_band_problems",
]

OffsetType = Literal["wear", "geometry"]

#: Keys of the ``[safety]`` table.
SAFETY_KEYS = frozenset({"dead_band", "gain", "reject_band", "cumulative_limit", "uncertainty", "guard_band", "ewma"})
#: Extra keys a ``[wks.ID]`` or ``[tools.ID]`` table may hold.
REGISTER_KEYS = frozenset({"cost", "offset", "number", "edge", "dead_band", "gain", "cumulative_limit"})
#: Keys of a ``[safety.dimensions.ID]`` table.
DIMENSION_KEYS = frozenset({"uncertainty", "reject_band"})


@dataclass(frozen=True, slots=True)
class RegisterPolicy:
    """Per-register preferences (``Register.policy``); ``None`` means the model-wide setting.

    ``cost`` is the register's weight in the least-norm stage (Σ cost·x², eq. 9 with
    weights); ``offset`` the offset the change goes to (None: wear for a tool, geometry
    for a WKS, see :meth:`offset_type`).
    """

    cost: float = 1.0
    offset: OffsetType | None = None
    number: int | None = None
    edge: int | None = None
    dead_band: float | None = None
    gain: float | None = None
    cumulative_limit: float | None = None

    def offset_type(self, kind: str) -> str:
        """The offset a change goes to: the declared one, else wear for a tool and geometry for a WKS."""
        return self.offset or ("wear" if kind == "tool" else "geometry")


@dataclass(frozen=True, slots=True)
class SafetySettings:
    """The model's ``[safety]`` table (``ProcessModel.safety``) with its per-dimension settings.

    Per-register settings are on each register (``Register.policy``).
    """

    dead_band: float | None = None
    gain: float = 1.0
    reject_band: float | None = None
    cumulative_limit: float | None = None
    uncertainty: float = 0.0
    guard_band: float = 1.0
    ewma: float = 1.0
    dimension_uncertainty: Mapping[str, float] = field(default_factory=dict)
    dimension_reject_band: Mapping[str, float] = field(default_factory=dict)


def _num(
    report: Callable[[str], None], value: Any, low: float, high: float = math.inf, *, open_low: bool = False
) -> float | None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and (value > low or (not open_low and value == low)) and value <= high:
        return float(value)
    bracket = "(" if open_low else "["
    upper = "∞)" if high == math.inf else f"{high:g}]"
    report(f"expected a number in {bracket}{low:g}, {upper}, found {value!r}")
    return None


def _slot(value: Any, report: Callable[[str], None]) -> int | None:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 99999:
        return value
    report(f"expected a whole number in [0, 99999], found {value!r}")
    return None


def _offset(value: Any, report: Callable[[str], None]) -> str | None:
    if value in ("wear", "geometry"):
        return str(value)
    report(f'expected "wear" or "geometry", found {value!r}')
    return None


_REGISTER_PARSERS: dict[str, Callable[[Any, Callable[[str], None]], Any]] = {
    "cost": lambda v, r: _num(r, v, 0.0, open_low=True),
    "offset": _offset,
    "number": _slot,
    "edge": _slot,
    "dead_band": lambda v, r: _num(r, v, 0.0),
    "gain": lambda v, r: _num(r, v, 0.0, 1.0, open_low=True),
    "cumulative_limit": lambda v, r: _num(r, v, 0.0, open_low=True),
}


def parse_register_policy(table: Mapping[str, Any], report: Callable[[str, str], None]) -> RegisterPolicy:
    """The per-register keys of a ``[wks.ID]`` / ``[tools.ID]`` table (:data:`REGISTER_KEYS`; others ignored).

    ``report(key, message)`` adds a problem at that key of the table; a bad value
    falls back to the model-wide setting so every problem is reported in one pass.
    """
    values: dict[str, Any] = {}
    for key, parse in _REGISTER_PARSERS.items():
        if key in table:
            value = parse(table[key], functools.partial(report, key))
            if value is not None:
                values[key] = value
    return RegisterPolicy(**values) if values else _DEFAULT_POLICY


_DEFAULT_POLICY = RegisterPolicy()


def parse_safety(value: Any, dimension_ids: Collection[str], report: Callable[[str, str], None]) -> SafetySettings:
    """The ``[safety]`` table, validated against the model's dimension IDs.

    ``report(key, message)`` adds a problem at ``safety.<key>``; a bad value falls
    back to its default so every problem is reported in one pass.
    """
    if not isinstance(value, Mapping):
        report("", f"expected a table, found {type(value).__name__}")
        value = {}
    for name in value:
        if name not in SAFETY_KEYS and name != "dimensions":
            report(name, f"unknown key (expected one of: {', '.join(sorted(SAFETY_KEYS | {'dimensions'}))})")

    def get(name: str, low: float, high: float = math.inf, *, open_low: bool = False) -> float | None:
        if name not in value:
            return None
        return _num(lambda m: report(name, m), value[name], low, high, open_low=open_low)

    uncertainty: dict[str, float] = {}
    reject: dict[str, float] = {}
    known = set(dimension_ids)
    dims = value.get("dimensions", {})
    if not isinstance(dims, Mapping):
        report("dimensions", "expected a table of dimension IDs")
        dims = {}
    for did, table in dims.items():
        key = f"dimensions.{did}"
        if did not in known:
            report(key, f"unknown dimension {did!r}")
            continue
        if not isinstance(table, Mapping):
            report(key, "expected a table (uncertainty, reject_band)")
            continue
        for name in table:
            if name not in DIMENSION_KEYS:
                report(f"{key}.{name}", f"unknown key (expected one of: {', '.join(sorted(DIMENSION_KEYS))})")
        if "uncertainty" in table:
            u = _num(functools.partial(report, f"{key}.uncertainty"), table["uncertainty"], 0.0)
            if u is not None:
                uncertainty[did] = u
        if "reject_band" in table:
            r = _num(functools.partial(report, f"{key}.reject_band"), table["reject_band"], 0.0, open_low=True)
            if r is not None:
                reject[did] = r
    gain = get("gain", 0.0, 1.0, open_low=True)
    u_all = get("uncertainty", 0.0)
    guard = get("guard_band", 0.0, 1.0)
    lam = get("ewma", 0.0, 1.0, open_low=True)
    return SafetySettings(
        dead_band=get("dead_band", 0.0),
        gain=1.0 if gain is None else gain,
        reject_band=get("reject_band", 0.0, open_low=True),
        cumulative_limit=get("cumulative_limit", 0.0, open_low=True),
        uncertainty=0.0 if u_all is None else u_all,
        guard_band=1.0 if guard is None else guard,
        ewma=1.0 if lam is None else lam,
        dimension_uncertainty=uncertainty,
        dimension_reject_band=reject,
    )


def guard_band_problems(safety: SafetySettings, dimensions: Collection[Dimension]) -> list[tuple[str, str]]:
    """Where the guard band leaves a dimension no conformance zone: (key of its ``U``, message) pairs.

    The limits shrink by g·U at each end (ISO 14253-1, :func:`setupfix.correction.safety.guard_limits`);
    when 2·g·U reaches the tolerance width (g·U the radius of a position zone) nothing can be proven
    in tolerance and no correction means anything, so the model is refused rather than solved on a
    collapsed zone.  One pair for the ``[safety] uncertainty`` shared by several dimensions (named),
    one per ``[safety.dimensions.ID] uncertainty``.
    """
    g = safety.guard_band
    shared: list[str] = []
    out: list[tuple[str, str]] = []
    for dim in dimensions:
        own = dim.id in safety.dimension_uncertainty
        u = safety.dimension_uncertainty.get(dim.id, safety.uncertainty)
        if u <= 0 or g <= 0:
            continue
        room = dim.upper if dim.zone else dim.upper - dim.lower  # a zone: its radius
        used = g * u if dim.zone else 2 * g * u
        if not math.isfinite(room) or used < room - 1e-12:
            continue
        what = f"{dim.id} ({dim.name}): guard band {g:g} × U {u:g} " + (
            f"reaches its zone's radius {room:g}" if dim.zone else f"on each side reaches its tolerance width {room:g}"
        )
        if own:
            out.append((f"dimensions.{dim.id}.uncertainty", f"{what}: no conformance zone is left (ISO 14253-1)"))
        else:
            shared.append(what)
    if shared:
        more = f" and {len(shared) - 3} more" if len(shared) > 3 else ""
        out.insert(
            0,
            (
                "uncertainty",
                f"no conformance zone is left (ISO 14253-1) for {len(shared)} dimension(s): "
                + "; ".join(shared[:3])
                + more
                + ": lower uncertainty or guard_band, or give those dimensions their own U",
            ),
        )
    return out
