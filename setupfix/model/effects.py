"""The ``[effects]`` section of a process model: effects found by ``setupfix diagnose``.

A model written with ``diagnose --augment OUT.toml`` is the input model unchanged plus
this section; a model without it loads as before.  Layout::

    [effects]
    origin = "2026-11-02T08:00:00"   # time 0 of the drift terms (ISO 8601)
    cycle_hours = 0.333              # typical interval between two cycles [h]
    last_hours = 13.0                # time of the last cycle diagnosed, from origin [h]

    [effects.E1]
    kind = "drift"                   # drift | thermal | wear | scale | position | rotation | relation
                                     # | group | level | process
    shape = "linear"                 # drift: linear | saturating (then tau [h])
    estimate = 0.0020                # coefficient, in `unit`
    stderr = 0.00001
    unit = "mm/h"
    target = "all tools ~ time"      # free text, for people

Keys by kind: thermal ``channel`` and ``reference`` [°C]; wear ``register`` (a tool);
position ``axis`` (and ``along``: the slope acts on that axis's errors only); rotation
``register`` (a WKS turned about the spindle axis, estimate in radians); relation
``register`` and ``dimension`` (and ``registers``, every
register the series could not tell from it, when more than one); group ``group``; level
``at`` [h from ``origin``: cycles cut at or after it are shifted], ``cycle`` (the first
cycle after the step, for people) and ``register`` (absent: every tool alike); process
``channel`` (a column of the process log, or ``name=level`` for a categorical level),
``reference`` (the channel's value the term is zero at, in the channel's unit), ``span``
(the channel's range over the series) and ``register`` (absent: every tool alike).  Each
effect adds ``estimate`` × its covariate to the deviations (see
:mod:`setupfix.diagnose.terms`).  Everything here is plain data: parse, validate
against the model; :mod:`setupfix.model.effects_toml` writes it.

Every value is checked when the model loads (a forecast goes into a machine): numbers
finite, ``origin`` an ISO 8601 time in 1970…2200, and within these bounds (lengths in
mm, converted to the model unit):

=======================  ================  =================================================
key                      bound             why
=======================  ================  =================================================
drift (linear)           |β| ≤ 1 mm/h      warming spindles and frames drift µm per hour
drift (saturating)       |β| ≤ 10 mm       the largest correction a register may take
thermal                  |β| ≤ 1 mm/°C     a 10 m steel part grows 0.12 mm/°C
wear                     |β| ≤ 1 mm/cycle  a tool losing a millimetre per part is broken
scale, position          |β| ≤ 0.01        1 %: steel grows that much over 850 °C
rotation                 |β| ≤ 0.01 rad    0.57°: a part clamped that far askew is no setup
relation                 |β| ≤ 1000        the bound on every relation weight of the model
group, level             |β| ≤ 10 mm       the largest correction a register may take
process                  |β|·span ≤ 10 mm  over the channel's range seen, at most a correction
``span``                 0 < span ≤ 1e12   any unit (rpm, mm/min, minutes, 0/1)
process ``reference``    |ref| ≤ 1e12      any unit
``at``                   0 … 876,600 h     a hundred years after ``origin``
``stderr``               0 … 1000 × bound  a statistic: only absurd values are refused
``tau``                  0 < τ ≤ 100,000 h saturation over more than ~11 years is linear
``reference``            −50 … 200 °C      shop, coolant and spindle temperatures
``cycle_hours``          0 … 8,784 h       one cycle per year at the slowest
``last_hours``           0 … 876,600 h     a hundred years after ``origin``
=======================  ================  =================================================
"""

from __future__ import annotations

import math
import sys
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import date, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from setupfix.core.errors import ModelError, SourceLocation
from setupfix.core.units import length_factor

if TYPE_CHECKING:  # the model holds its [effects] section: process imports this module
    from setupfix.model.process import ProcessModel

__all__ = ["ModelEffect", "EffectsSection", "effects_from_dict", "parse_effects", "load_effects", "EFFECT_KINDS"]

EFFECT_KINDS: tuple[str, ...] = (
    "drift",
    "thermal",
    "wear",
    "scale",
    "position",
    "rotation",
    "relation",
    "group",
    "level",
    "process",
)

EFFECT_KEYS = {
    "kind",
    "shape",
    "tau",
    "estimate",
    "stderr",
    "unit",
    "target",
    "channel",
    "reference",
    "register",
    "dimension",
    "axis",
    "along",
    "group",
    "registers",
    "description",
    "comment",
    "note",
    "notes",
    "at",
    "cycle",
    "span",
}
_REQUIRED = {
    "drift": (),
    "thermal": ("channel",),
    "wear": ("register",),
    "scale": (),
    "position": ("axis",),
    "rotation": ("register",),
    "relation": ("register", "dimension"),
    "group": ("group",),
    "level": ("at",),
    "process": ("channel", "span"),
}


@dataclass(frozen=True)
class ModelEffect:
    """One effect of the ``[effects]`` section (see the module text for the keys)."""

    id: str
    kind: str
    estimate: float
    stderr: float | None = None
    unit: str = ""
    target: str = ""
    shape: str = "linear"
    tau: float | None = None
    channel: str | None = None
    reference: float = 0.0
    register: str | None = None
    dimension: str | None = None
    axis: str | None = None
    group: str | None = None
    registers: tuple[str, ...] = ()
    along: str | None = None
    at: float | None = None
    cycle: str | None = None
    span: float | None = None


@dataclass(frozen=True)
class EffectsSection:
    """The whole section: its effects and the time base of the drift terms."""

    effects: tuple[ModelEffect, ...] = ()
    origin: str | None = None
    cycle_hours: float | None = None
    last_hours: float | None = None
    notes: tuple[str, ...] = field(default=())

    def __bool__(self) -> bool:
        return bool(self.effects)


def _num(value: Any) -> bool:
    return (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and abs(value) <= sys.float_info.max
        and math.isfinite(value)
    )


#: Bound on |estimate| per kind (and drift shape), in mm-based units (module table).
ESTIMATE_BOUNDS: dict[str, tuple[float, bool]] = {
    # kind: (bound, is the bound a length that scales with the model unit)
    "drift": (1.0, True),
    "saturating": (10.0, True),
    "thermal": (1.0, True),
    "wear": (1.0, True),
    "scale": (0.01, False),
    "position": (0.01, False),
    "rotation": (0.01, False),
    "relation": (1000.0, False),
    "group": (10.0, True),
    "level": (10.0, True),
    "process": (10.0, True),
}
#: Bounds of the section's time base and of the other numbers (module table).
HEAD_BOUNDS: dict[str, tuple[float, float]] = {"cycle_hours": (0.0, 8784.0), "last_hours": (0.0, 876_600.0)}
TAU_HOURS = 100_000.0
REFERENCE_CELSIUS = (-50.0, 200.0)
ORIGIN_YEARS = (1970, 2200)
PROCESS_VALUE = 1e12
AT_HOURS = 876_600.0
STDERR_FACTOR = 1000.0


def _origin_problem(value: Any) -> str | None:
    """Why ``origin`` is not a usable time (None when it is)."""
    if isinstance(value, datetime):
        moment = value
    elif isinstance(value, date) and not isinstance(value, datetime):
        moment = datetime(value.year, value.month, value.day)
    elif isinstance(value, str):
        try:
            moment = datetime.fromisoformat(value.strip().replace("Z", "+00:00"))
        except ValueError:
            return f"expected an ISO 8601 time (e.g. 2026-11-02T08:00:00), found {value[:40]!r}"
    else:
        return f"expected an ISO 8601 time (e.g. 2026-11-02T08:00:00), found {_shown(value)}"
    if not ORIGIN_YEARS[0] <= moment.year <= ORIGIN_YEARS[1]:
        return f"year {moment.year} is outside {ORIGIN_YEARS[0]}…{ORIGIN_YEARS[1]}"
    return None


def _shown(value: Any) -> str:
    """A value for a message, short (huge integers and tables named, not printed)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return "an integer beyond the float range" if abs(value) > sys.float_info.max else f"{value:.3e}"
    text = repr(value) if not isinstance(value, (dict, list)) else f"a {type(value).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


def effects_from_dict(
    section: Mapping[str, Any] | None, model: ProcessModel, source: str = "<model>"
) -> EffectsSection:
    """Validate an ``[effects]`` table against ``model``.

    Raises
    ------
    ModelError
        One line per problem, each naming ``source`` and the key path.
    """
    problems: list[str] = []

    def bad(key: str, message: str) -> None:
        problems.append(str(ModelError(message, location=SourceLocation(source, key=key))))

    section_read = _validated(section, model, bad)
    if problems:
        raise ModelError("\n".join(problems))
    return section_read


def _validated(
    section: Mapping[str, Any] | None, model: ProcessModel, bad: Callable[[str, str], None]
) -> EffectsSection:
    """The section read, every problem given to ``bad(key, message)`` (key from the document's top)."""
    if not section:
        return EffectsSection()
    problems = _Count(bad)
    bad = problems.add
    head: dict[str, Any] = {}
    for name in ("origin", "cycle_hours", "last_hours"):
        if name in section:
            head[name] = section[name]
    origin = head.get("origin")
    why = None if origin is None else _origin_problem(origin)
    if why is not None:
        bad("effects.origin", why)
        origin = None
    elif origin is not None and not isinstance(origin, str):
        origin = str(origin)  # TOML local date-times arrive as datetime objects
    for name in ("cycle_hours", "last_hours"):
        low, high = HEAD_BOUNDS[name]
        if name in head and not (_num(head[name]) and low <= head[name] <= high):
            bad(f"effects.{name}", f"expected a number of hours in [{low:g}, {high:g}], found {_shown(head[name])}")
            head.pop(name)
    length = length_factor("mm", model.unit)
    regs = set(model.register_ids)
    tools = {t.id for t in model.tools}
    wks_ids = {w.base for w in model.wks}
    dims = set(model.dimension_ids)
    groups = {d.group for d in model.dimensions if d.group}
    effects = []
    for eid, raw in section.items():
        if eid in ("origin", "cycle_hours", "last_hours"):
            continue
        key = f"effects.{eid}"
        if not isinstance(raw, Mapping):
            bad(key, f"expected a table [effects.{eid}] or one of origin, cycle_hours, last_hours")
            continue
        for k in raw:
            if k not in EFFECT_KEYS:
                bad(f"{key}.{k}", f"unknown key (expected one of: {', '.join(sorted(EFFECT_KEYS))})")
        kind = raw.get("kind")
        if kind not in EFFECT_KINDS:
            bad(f"{key}.kind", f"expected one of {', '.join(EFFECT_KINDS)}, found {kind!r}")
            continue
        est: Any = raw.get("estimate")
        if not _num(est):
            bad(f"{key}.estimate", f"expected a finite number, found {_shown(est)}")
            continue
        shape_of = "saturating" if kind == "drift" and raw.get("shape") == "saturating" else str(kind)
        bound, scales = ESTIMATE_BOUNDS[shape_of]
        bound *= length if scales else 1.0
        if abs(est) > bound and kind != "process":
            per = {"drift": "/h", "thermal": "/°C", "wear": "/cycle"}.get(shape_of, "")
            what = f"{model.unit}{per}" if scales else "(a ratio)" if kind != "relation" else "(a weight)"
            label = "saturating drift" if shape_of == "saturating" else str(kind)
            bad(f"{key}.estimate", f"estimate {est:g} is beyond the plausible ±{bound:g} {what} of a {label} effect")
        stderr_raw = raw.get("stderr")
        if stderr_raw is not None and not (_num(stderr_raw) and 0 <= stderr_raw <= STDERR_FACTOR * bound):
            bad(f"{key}.stderr", f"expected a number in [0, {STDERR_FACTOR * bound:g}], found {_shown(stderr_raw)}")
        if "tau" in raw and not (_num(raw["tau"]) and 0 < raw["tau"] <= TAU_HOURS):
            bad(f"{key}.tau", f"expected hours in (0, {TAU_HOURS:g}], found {_shown(raw['tau'])}")
        if kind == "process":
            if "reference" in raw and not (_num(raw["reference"]) and abs(raw["reference"]) <= PROCESS_VALUE):
                bad(
                    f"{key}.reference", f"expected a number within ±{PROCESS_VALUE:g}, found {_shown(raw['reference'])}"
                )
        elif "reference" in raw and not (
            _num(raw["reference"]) and REFERENCE_CELSIUS[0] <= raw["reference"] <= REFERENCE_CELSIUS[1]
        ):
            bad(
                f"{key}.reference",
                f"expected °C in [{REFERENCE_CELSIUS[0]:g}, {REFERENCE_CELSIUS[1]:g}], "
                f"found {_shown(raw['reference'])}",
            )
        for name in ("unit", "target", "shape", "channel", "register", "dimension", "axis", "group", "cycle"):
            if name in raw and not isinstance(raw[name], str):
                bad(f"{key}.{name}", f"expected a string, found {_shown(raw[name])}")
        for k in _REQUIRED[kind]:
            if k in ("at", "span"):
                if k not in raw:
                    bad(f"{key}.{k}", f"a {kind} effect needs {k} (a number)")
            elif not isinstance(raw.get(k), str):
                bad(f"{key}.{k}", f"a {kind} effect needs {k} (a string)")
        if "at" in raw and not (_num(raw["at"]) and 0 <= raw["at"] <= AT_HOURS):
            bad(f"{key}.at", f"expected hours in [0, {AT_HOURS:g}], found {_shown(raw['at'])}")
        span_raw: Any = raw.get("span")
        if "span" in raw and not (_num(span_raw) and 0 < span_raw <= PROCESS_VALUE):
            bad(f"{key}.span", f"expected a number in (0, {PROCESS_VALUE:g}], found {_shown(span_raw)}")
        elif kind == "process" and _num(span_raw) and abs(est) * span_raw > bound:
            bad(
                f"{key}.estimate",
                f"estimate {est:g} over the channel's span {span_raw:g} moves "
                f"{abs(est) * span_raw:g} {model.unit}, beyond the plausible ±{bound:g}",
            )
        if problems:
            continue
        shape = raw.get("shape", "linear")
        tau = raw.get("tau")
        if kind == "drift" and shape not in ("linear", "saturating"):
            bad(f"{key}.shape", f'expected "linear" or "saturating", found {shape!r}')
        if kind == "drift" and shape == "saturating" and not (_num(tau) and float(tau or 0) > 0):
            bad(f"{key}.tau", f"a saturating drift needs tau > 0 [h], found {tau!r}")
        if kind == "wear" and raw["register"] not in tools:
            bad(f"{key}.register", f"unknown tool {raw['register']!r}")
        if kind == "relation":
            if raw["register"] not in regs:
                bad(f"{key}.register", f"unknown register {raw['register']!r}")
            if raw["dimension"] not in dims:
                bad(f"{key}.dimension", f"unknown dimension {raw['dimension']!r}")
            alts = raw.get("registers", [])
            if not isinstance(alts, list) or not all(isinstance(r, str) and r in regs for r in alts):
                bad(f"{key}.registers", f"expected a list of register IDs, found {alts!r}")
        if kind in ("level", "process") and "register" in raw and raw["register"] not in regs:
            bad(f"{key}.register", f"unknown register {raw['register']!r}")
        if kind == "group" and raw["group"] not in groups:
            bad(f"{key}.group", f"unknown group {raw['group']!r}")
        if kind == "position" and raw["axis"] not in ("x", "y", "z"):
            bad(f"{key}.axis", f'expected "x", "y" or "z", found {raw["axis"]!r}')
        if kind == "position" and raw.get("along", "x") not in ("x", "y", "z"):
            bad(f"{key}.along", f'expected "x", "y" or "z", found {raw["along"]!r}')
        if kind == "rotation" and raw["register"] not in wks_ids:
            bad(f"{key}.register", f"unknown WKS {raw['register']!r} (a rotation turns one WKS)")
        stderr = raw.get("stderr")
        effects.append(
            ModelEffect(
                id=str(eid),
                kind=str(kind),
                estimate=float(est or 0),
                stderr=float(stderr or 0) if _num(stderr) else None,
                unit=str(raw.get("unit", "")),
                target=str(raw.get("target", "")),
                shape=str(shape),
                tau=float(tau or 0) if _num(tau) else None,
                channel=raw.get("channel"),
                reference=float(raw["reference"]) if _num(raw.get("reference")) else 0.0,
                register=raw.get("register"),
                dimension=raw.get("dimension"),
                axis=raw.get("axis"),
                along=raw.get("along") if kind == "position" else None,
                group=raw.get("group"),
                registers=tuple(raw.get("registers", ())) if kind == "relation" else (),
                at=float(raw["at"]) if kind == "level" else None,
                cycle=raw.get("cycle") if kind == "level" else None,
                span=float(raw["span"]) if kind == "process" else None,
            )
        )
    return EffectsSection(tuple(effects), origin, head.get("cycle_hours"), head.get("last_hours"))


class _Count:
    """Passes problems on and counts them (an effect is built only while none was found)."""

    def __init__(self, report: Callable[[str, str], None]) -> None:
        self.report = report
        self.n = 0

    def add(self, key: str, message: str) -> None:
        self.n += 1
        self.report(key, message)

    def __bool__(self) -> bool:
        return self.n > 0


def parse_effects(value: Any, model: ProcessModel, report: Any) -> EffectsSection:
    """The ``[effects]`` table as the loader reads it: validated once, when the model loads.

    ``report(key, message)`` adds a problem (``key`` relative to the section).
    """
    if not isinstance(value, Mapping):
        report("", "expected a table [effects]")
        return EffectsSection()
    found: list[tuple[str, str]] = []
    section = _validated(value, model, lambda key, message: found.append((key, message)))
    for key, message in found:
        report(key.removeprefix("effects").removeprefix("."), message)
    return EffectsSection() if found else section


def load_effects(path: str | Path, model: ProcessModel) -> EffectsSection:
    """Read the ``[effects]`` section of a model file (empty when it has none).

    Raises
    ------
    ModelError
        If the file cannot be read or the section is invalid.
    """
    try:
        doc = tomllib.loads(Path(path).read_bytes().decode("utf-8-sig"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ModelError(f"cannot read effects: {exc}", location=SourceLocation(str(path))) from None
    section = doc.get("effects")
    if section is not None and not isinstance(section, Mapping):
        raise ModelError("expected a table [effects]", location=SourceLocation(str(path), key="effects"))
    return effects_from_dict(section, model, str(path))
