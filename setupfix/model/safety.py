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
``mean_of``            1 (the part alone)         decide on the mean of the last n parts
``min_parts``          1 (every part)             parts measured since a register's last change
                                                  before it moves again
=====================  =========================  =======================================

``dead_band`` may also be written ``"N %"``: a share of each dimension's tolerance width; the
correction is held unless some dimension's predicted change exceeds N % of its width (a
one-sided tolerance has no width: only the absolute band, 2 × resolution by default, holds
it).  Per register, ``dead_band = "N %"`` is N % of the narrowest tolerance width (divided by
the weight) among the dimensions the register moves.

The expanded uncertainty U (k = 2) of each dimension, in order of precedence: the report's own
``uncertainty`` column; the dimension's ``uncertainty`` (``[dimensions.ID]`` or
``[safety.dimensions.ID]``); ``[measurement] uncertainty`` (or ``[safety] uncertainty``); the
CMM's ``[measurement] mpe = [a, b]``, U = a + L/b µm with L the nominal size in mm
(:func:`mpe_uncertainty`); else none.  :attr:`SafetySettings.uncertainty_source` says where each
dimension's model value comes from (:data:`UNCERTAINTY_SOURCES`).

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
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal

from setupfix.core.errors import ParameterError

if TYPE_CHECKING:
    from setupfix.model.process import Dimension

__all__ = [
    "OffsetType",
    "RegisterPolicy",
    "MeasurementSettings",
    "Rules",
    "MEASUREMENT_KEYS",
    "UNCERTAINTY_SOURCES",
    "parse_measurement",
    "parse_rules",
    "mpe_uncertainty",
    "with_measurement",
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
SAFETY_KEYS = frozenset(
    {
        "dead_band",
        "gain",
        "reject_band",
        "cumulative_limit",
        "uncertainty",
        "guard_band",
        "ewma",
        "mean_of",
        "min_parts",
    }
)
#: Extra keys a ``[wks.ID]`` or ``[tools.ID]`` table may hold.
REGISTER_KEYS = frozenset({"cost", "offset", "number", "edge", "dead_band", "gain", "cumulative_limit", "min_parts"})
#: Keys of the ``[measurement]`` table.
MEASUREMENT_KEYS = frozenset({"uncertainty", "mpe"})
#: Where a dimension's U comes from, in order of precedence ("" where none is given).
UNCERTAINTY_SOURCES = ("report", "dimension", "measurement", "mpe")
#: Bound on ``mean_of`` and ``min_parts`` (parts).
MAX_PARTS = 1000
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
    dead_band_share: float | None = None
    min_parts: int | None = None

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
    dead_band_share: float | None = None
    mean_of: int = 1
    min_parts: int = 1
    uncertainty_source: Mapping[str, str] = field(default_factory=dict)

    def rules(self) -> Rules:
        """The model-wide rules (what ``replay`` runs when no ``--rules`` is given)."""
        return Rules(self.dead_band, self.dead_band_share, self.gain, self.mean_of, self.min_parts)

    def source_of(self, dimension_id: str) -> str:
        """Where the model's U of a dimension comes from (:data:`UNCERTAINTY_SOURCES`; "" where none)."""
        if dimension_id in self.uncertainty_source:
            return self.uncertainty_source[dimension_id]
        if dimension_id in self.dimension_uncertainty:
            return "dimension"
        return "measurement" if self.uncertainty > 0 else ""


@dataclass(frozen=True, slots=True)
class Rules:
    """A rule set as a share of the tolerance (``[safety]`` or ``replay --rules``), model-wide.

    ``dead_band`` [model unit] holds when every register change is within it (None: 2 ×
    resolution); ``dead_band_share`` (0.1 for "10 %") holds when every dimension's predicted
    change is within that share of its tolerance width; ``gain`` in (0, 1] is the feedback
    fraction applied; ``mean_of`` the parts the decision averages; ``min_parts`` the parts
    measured since a register's last change before it moves again.
    """

    dead_band: float | None = None
    dead_band_share: float | None = None
    gain: float = 1.0
    mean_of: int = 1
    min_parts: int = 1

    def to_json(self) -> dict[str, object]:
        """As the replay's JSON spells it (``"dead_band": "10 %"`` for a share)."""
        band: object = self.dead_band
        if self.dead_band_share is not None:
            band = f"{self.dead_band_share * 100:g} %"
        return {"dead_band": band, "gain": self.gain, "mean_of": self.mean_of, "min_parts": self.min_parts}


@dataclass(frozen=True, slots=True)
class MeasurementSettings:
    """The ``[measurement]`` table: the CMM's expanded uncertainty U (k = 2) or its MPE formula.

    ``uncertainty`` [model unit] for every dimension without its own; ``mpe`` = (a, b):
    MPE_E = a + L/b µm (L the nominal size in mm), taken as U where no other value is given.
    """

    uncertainty: float | None = None
    mpe: tuple[float, float] | None = None


def mpe_uncertainty(a: float, b: float, nominal: float, unit: str = "mm") -> float:
    """U from a CMM's length-measuring error MPE_E = a + L/b µm, in the model unit.

    ISO 10360-2 states the MPE of a length L [mm] as a + L/b [µm]; L is the dimension's
    nominal size (its absolute value; a position zone's nominal is its location).

    Parameters
    ----------
    a : float [µm], b : float [mm/µm] (> 0)
    nominal : float [model unit]
    unit : {"mm", "inch"}

    Returns
    -------
    float [model unit]
    """
    per_mm = 25.4 if unit == "inch" else 1.0
    length_mm = abs(nominal) * per_mm
    return (a + length_mm / b) / 1000.0 / per_mm


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


def _share(value: Any, report: Callable[[str], None]) -> float | None:
    """A share written ``"N %"`` (0 < N ≤ 100) as a fraction, else None after a report."""
    text = value.strip() if isinstance(value, str) else ""
    if text.endswith("%"):
        try:
            n = float(text[:-1].strip())
        except ValueError:
            n = math.nan
        if math.isfinite(n) and 0 < n <= 100:
            return n / 100.0
    report(f'expected a share of the tolerance written "N %" with 0 < N ≤ 100, found {value!r}')
    return None


def _band(value: Any, report: Callable[[str], None]) -> tuple[float | None, float | None]:
    """A dead band: (absolute [unit], share) with one of them set, or (None, None) after a report."""
    if isinstance(value, str):
        return None, _share(value, report)
    return _num(report, value, 0.0), None


def _parts(value: Any, report: Callable[[str], None]) -> int | None:
    if isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= MAX_PARTS:
        return value
    report(f"expected a whole number of parts in [1, {MAX_PARTS}], found {value!r}")
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
    "gain": lambda v, r: _num(r, v, 0.0, 1.0, open_low=True),
    "cumulative_limit": lambda v, r: _num(r, v, 0.0, open_low=True),
    "min_parts": _parts,
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
    if "dead_band" in table:
        absolute, share = _band(table["dead_band"], functools.partial(report, "dead_band"))
        if absolute is not None:
            values["dead_band"] = absolute
        if share is not None:
            values["dead_band_share"] = share
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
    band, share = _band(value["dead_band"], lambda m: report("dead_band", m)) if "dead_band" in value else (None, None)
    mean_of = _parts(value["mean_of"], lambda m: report("mean_of", m)) if "mean_of" in value else None
    min_parts = _parts(value["min_parts"], lambda m: report("min_parts", m)) if "min_parts" in value else None
    if mean_of is not None and mean_of > 1 and lam is not None and lam < 1:
        report("mean_of", "give either ewma (a weighted mean) or mean_of (a plain mean), not both")
    return SafetySettings(
        dead_band=band,
        dead_band_share=share,
        mean_of=mean_of or 1,
        min_parts=min_parts or 1,
        gain=1.0 if gain is None else gain,
        reject_band=get("reject_band", 0.0, open_low=True),
        cumulative_limit=get("cumulative_limit", 0.0, open_low=True),
        uncertainty=0.0 if u_all is None else u_all,
        guard_band=1.0 if guard is None else guard,
        ewma=1.0 if lam is None else lam,
        dimension_uncertainty=uncertainty,
        dimension_reject_band=reject,
    )


def parse_measurement(value: Any, report: Callable[[str, str], None]) -> MeasurementSettings:
    """The ``[measurement]`` table (:data:`MEASUREMENT_KEYS`).

    ``report(key, message)`` adds a problem at ``measurement.<key>``; a bad value is left
    out so every problem is reported in one pass.
    """
    if not isinstance(value, Mapping):
        report("", f"expected a table, found {type(value).__name__}")
        value = {}
    for name in value:
        if name not in MEASUREMENT_KEYS:
            report(name, f"unknown key (expected one of: {', '.join(sorted(MEASUREMENT_KEYS))})")
    u = _num(lambda m: report("uncertainty", m), value["uncertainty"], 0.0) if "uncertainty" in value else None
    mpe: tuple[float, float] | None = None
    if "mpe" in value:
        raw = value["mpe"]
        pair = raw if isinstance(raw, list) and len(raw) == 2 else None
        a = _num(lambda m: None, pair[0], 0.0) if pair is not None else None
        b = _num(lambda m: None, pair[1], 0.0, open_low=True) if pair is not None else None
        if a is None or b is None:
            report("mpe", f"expected [a, b] with a ≥ 0 µm and b > 0 (MPE = a + L/b µm), found {raw!r}")
        else:
            mpe = (a, b)
    if u is not None and mpe is not None:
        report("mpe", "give either uncertainty (U for every dimension) or mpe (U from the length), not both")
    return MeasurementSettings(u, mpe)


def with_measurement(
    safety: SafetySettings,
    measurement: MeasurementSettings,
    own: Mapping[str, float],
    dimensions: Collection[Dimension],
    unit: str,
    report: Callable[[str, str], None],
) -> SafetySettings:
    """The safety settings with every model source of U folded in, and where each value comes from.

    ``own``: the ``[dimensions.ID] uncertainty`` values.  Precedence (module docstring): the
    dimension's own value (``[dimensions.ID]`` or ``[safety.dimensions.ID]``, given once) →
    ``[measurement] uncertainty`` (or ``[safety] uncertainty``, given once) → ``[measurement]
    mpe`` → none.  ``report(key, message)`` names a value given twice, at its full key path.
    """
    values = dict(safety.dimension_uncertainty)
    source = {d: "dimension" for d in values}
    for did, u in own.items():
        if did in values:
            report(f"dimensions.{did}.uncertainty", "also given in [safety.dimensions]: give it once")
            continue
        values[did] = u
        source[did] = "dimension"
    shared = safety.uncertainty
    if measurement.uncertainty is not None:
        if shared > 0:
            report("measurement.uncertainty", "also given as [safety] uncertainty: give it once")
        shared = measurement.uncertainty
    for dim in dimensions:
        if dim.id in values:
            continue
        if shared > 0:
            source[dim.id] = "measurement"
        elif measurement.mpe is not None:
            values[dim.id] = mpe_uncertainty(*measurement.mpe, dim.nominal, unit)
            source[dim.id] = "mpe"
    return replace(safety, uncertainty=shared, dimension_uncertainty=values, uncertainty_source=source)


def parse_rules(text: str) -> Rules:
    """A rule set written ``dead_band=10 %,gain=0.5,mean_of=3,min_parts=2`` (``replay --rules``).

    Keys as in ``[safety]`` (``dead_band`` an absolute length in the model unit or ``"N %"``);
    keys not given keep their defaults.

    Raises
    ------
    ParameterError
        An unknown key, a bad value, or a key given twice, named in one line.
    """
    known = ("dead_band", "gain", "mean_of", "min_parts")
    values: dict[str, Any] = {}
    problems: list[str] = []
    for item in (t for t in text.split(",") if t.strip()):
        key, eq, raw = item.partition("=")
        key = key.strip()
        if not eq or key not in known:
            problems.append(f"{item.strip()!r}: expected KEY=VALUE with KEY one of {', '.join(known)}")
            continue
        if key in values:
            problems.append(f"{key}: given twice")
            continue
        raw = raw.strip()

        def say(message: str, key: str = key) -> None:
            problems.append(f"{key}: {message}")

        if key == "dead_band":
            if raw.endswith("%"):
                values["dead_band_share"] = _share(raw, say)
            else:
                values["dead_band"] = _num(say, _number(raw), 0.0)
        elif key == "gain":
            values[key] = _num(say, _number(raw), 0.0, 1.0, open_low=True)
        else:
            values[key] = _parts(_number(raw), say)
    if problems:
        raise ParameterError(f"--rules {text!r}: " + "; ".join(problems))
    return Rules(**{k: v for k, v in values.items() if v is not None})


def _number(text: str) -> Any:
    """A number in a ``--rules`` value (an int where it is written as one), else the text itself."""
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text


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
        if u <= 0 or g <= 0 or safety.source_of(dim.id) == "mpe":  # the CMM's own: a warning, not a refusal
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
