"""The ``[effects]`` section of a process model: effects found by ``setupfix diagnose``.

A model written with ``diagnose --augment OUT.toml`` is the input model unchanged plus
this section; a model without it loads as before.  Layout::

    [effects]
    origin = "2026-11-02T08:00:00"   # time 0 of the drift terms (ISO 8601)
    cycle_hours = 0.333              # typical interval between two cycles [h]
    last_hours = 13.0                # time of the last cycle diagnosed, from origin [h]

    [effects.E1]
    kind = "drift"                   # drift | thermal | wear | scale | position | relation | group
    shape = "linear"                 # drift: linear | saturating (then tau [h])
    estimate = 0.0020                # coefficient, in `unit`
    stderr = 0.00001
    unit = "mm/h"
    target = "all tools ~ time"      # free text, for people

Keys by kind: thermal ``channel`` and ``reference`` [°C]; wear ``register`` (a tool);
position ``axis``; relation ``register`` and ``dimension`` (and ``registers``, every
register the series could not tell from it, when more than one); group ``group``.  Each
effect adds ``estimate`` × its covariate to the deviations (see
:mod:`setupfix.diagnose.terms`).  Everything here is plain data: parse, validate
against the model, and write.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from setupfix.errors import ModelError, SourceLocation

if TYPE_CHECKING:  # the model holds its [effects] section: process imports this module
    from setupfix.model.process import ProcessModel

__all__ = ["ModelEffect", "EffectsSection", "effects_from_dict", "parse_effects", "load_effects",
           "effects_toml", "with_effects", "EFFECT_KINDS"]

EFFECT_KINDS: tuple[str, ...] = ("drift", "thermal", "wear", "scale", "position", "relation", "group")

_KEYS = {"kind", "shape", "tau", "estimate", "stderr", "unit", "target", "channel", "reference", "register",
         "dimension", "axis", "group", "registers", "description", "comment", "note", "notes"}
_REQUIRED = {"drift": (), "thermal": ("channel",), "wear": ("register",), "scale": (), "position": ("axis",),
             "relation": ("register", "dimension"), "group": ("group",)}


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
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def effects_from_dict(section: Mapping[str, Any] | None, model: ProcessModel,
                      source: str = "<model>") -> EffectsSection:
    """Validate an ``[effects]`` table against ``model``.

    Raises
    ------
    ModelError
        One line per problem, each naming ``source`` and the key path.
    """
    if not section:
        return EffectsSection()
    problems: list[str] = []

    def bad(key: str, message: str) -> None:
        problems.append(str(ModelError(message, location=SourceLocation(source, key=key))))

    head: dict[str, Any] = {}
    for name in ("origin", "cycle_hours", "last_hours"):
        if name in section:
            head[name] = section[name]
    origin = head.get("origin")
    if origin is not None and not isinstance(origin, str):
        origin = str(origin)  # TOML local date-times arrive as datetime objects
    for name in ("cycle_hours", "last_hours"):
        if name in head and not _num(head[name]):
            bad(f"effects.{name}", f"expected a number, found {head[name]!r}")
            head.pop(name)
    regs = set(model.register_ids)
    tools = {t.id for t in model.tools}
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
            if k not in _KEYS:
                bad(f"{key}.{k}", f"unknown key (expected one of: {', '.join(sorted(_KEYS))})")
        kind = raw.get("kind")
        if kind not in EFFECT_KINDS:
            bad(f"{key}.kind", f"expected one of {', '.join(EFFECT_KINDS)}, found {kind!r}")
            continue
        est = raw.get("estimate")
        if not _num(est):
            bad(f"{key}.estimate", f"expected a number, found {est!r}")
            continue
        for k in _REQUIRED[kind]:
            if not isinstance(raw.get(k), str):
                bad(f"{key}.{k}", f"a {kind} effect needs {k} (a string)")
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
        if kind == "group" and raw["group"] not in groups:
            bad(f"{key}.group", f"unknown group {raw['group']!r}")
        if kind == "position" and raw["axis"] not in ("x", "y", "z"):
            bad(f"{key}.axis", f'expected "x", "y" or "z", found {raw["axis"]!r}')
        stderr = raw.get("stderr")
        effects.append(ModelEffect(
            id=str(eid), kind=str(kind), estimate=float(est or 0),
            stderr=float(stderr or 0) if _num(stderr) else None,
            unit=str(raw.get("unit", "")), target=str(raw.get("target", "")), shape=str(shape),
            tau=float(tau or 0) if _num(tau) else None, channel=raw.get("channel"),
            reference=float(raw["reference"]) if _num(raw.get("reference")) else 0.0,
            register=raw.get("register"), dimension=raw.get("dimension"), axis=raw.get("axis"),
            group=raw.get("group"),
            registers=tuple(raw.get("registers", ())) if kind == "relation" else ()))
    if problems:
        raise ModelError("\n".join(problems))
    return EffectsSection(tuple(effects), origin, head.get("cycle_hours"), head.get("last_hours"))


def parse_effects(value: Any, model: ProcessModel, report: Any) -> EffectsSection:
    """The ``[effects]`` table as the loader reads it: validated once, when the model loads.

    ``report(key, message)`` adds a problem (``key`` relative to the section).
    """
    if not isinstance(value, Mapping):
        report("", "expected a table [effects]")
        return EffectsSection()
    try:
        return effects_from_dict(value, model, model.source)
    except ModelError as exc:
        report("", exc.message)
        return EffectsSection()


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


def _value(v: Any) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(v)) if isinstance(v, float) else str(v)


def effects_toml(section: EffectsSection) -> str:
    """The ``[effects]`` section as TOML text, documented for the reader of the file."""
    out = [
        "# Effects found by `setupfix diagnose` that the relations above lack. Each adds",
        "# estimate x its covariate to the deviations (drift: hours since origin, or",
        "# 1 - exp(-t/tau); thermal: channel - reference; wear: cycles since the tool's last",
        "# change; scale: nominal; position: the dimension's coordinate; relation: the",
        "# register's change on that dimension; group: 1 on the group's dimensions).",
        "# `setupfix correct` adds the drift and wear expected until the next cycle, and maps",
        "# corrections through a relation whose register is named (registers: the ones the",
        "# series could not tell apart; with more than one the weight is not used).",
        "[effects]",
    ]
    if section.origin is not None:
        out.append(f"origin = {_value(section.origin)}")
    if section.cycle_hours is not None:
        out.append(f"cycle_hours = {section.cycle_hours!r}")
    if section.last_hours is not None:
        out.append(f"last_hours = {section.last_hours!r}")
    for e in section.effects:
        out += ["", f"[effects.{e.id}]", f'kind = "{e.kind}"']
        if e.kind == "drift":
            out.append(f'shape = "{e.shape}"')
            if e.tau is not None:
                out.append(f"tau = {e.tau!r}")
        for name in ("channel", "register", "dimension", "axis", "group"):
            value = getattr(e, name)
            if value is not None:
                out.append(f"{name} = {_value(value)}")
        if e.registers:
            out.append(f"registers = [{', '.join(_value(r) for r in e.registers)}]")
        if e.kind == "thermal":
            out.append(f"reference = {e.reference!r}")
        out.append(f"estimate = {e.estimate!r}")
        if e.stderr is not None:
            out.append(f"stderr = {e.stderr!r}")
        out += [f"unit = {_value(e.unit)}", f"target = {_value(e.target)}"]
    return "\n".join(out) + "\n"


_HEADER = re.compile(r"^\s*\[{1,2}\s*([^\]]+?)\s*\]{1,2}\s*(#.*)?$")
_MARK = "# Effects found by `setupfix diagnose`"


def with_effects(model_text: str, section: EffectsSection) -> str:
    """The model file's text with its ``[effects]`` tables replaced by ``section``.

    Every other line is kept as written (comments included); the comment block a
    previous ``--augment`` wrote above ``[effects]`` goes with the old section.
    """
    kept: list[str] = []
    skipping = False
    for line in model_text.splitlines():
        m = _HEADER.match(line)
        if m:
            name = m.group(1).strip().strip('"')
            was = skipping
            skipping = name == "effects" or name.startswith("effects.")
            if skipping and not was:
                block = len(kept)
                while block and kept[block - 1].lstrip().startswith("#"):
                    block -= 1
                marks = [i for i in range(block, len(kept)) if kept[i].startswith(_MARK)]
                if marks:
                    del kept[marks[0]:]
        if not skipping:
            kept.append(line)
    body = "\n".join(kept).rstrip()
    return (body + "\n\n" if body else "") + effects_toml(section)
