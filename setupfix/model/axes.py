"""The multi-axis keys of a process model (``../shared/spec/process-model.md``, *Multi-axis models*).

A file whose ``[process]`` table has ``axes`` describes the whole setup: every translation
component of every WKS, optionally a rotation about the spindle axis, tool lengths along the
spindle and tool radius registers, dimensions measured along an axis or a direction, sizes and
circular position zones.  :mod:`setupfix.model.loader` reads the keys every model shares and
calls the functions here for the multi-axis ones; every problem is added to the loader's
:class:`~setupfix.model.validate.Problems` with its key path (one line each, file and key).

Register components (one :class:`~setupfix.model.process.Register` each, in file order, a
WKS's components together): ``W1.X``/``.Y``/``.Z`` (translation, register ``G54``), ``W1.C``
(rotation, degrees, limit ``rotation_limit``), ``T5`` (tool length along the spindle, component
the spindle axis) and ``T5.R`` (tool radius, register the tool's ``radius`` key, limit
``radius_limit``, default the tool's limit).

Sanity ranges of the rotation keys [degrees]: ``rotation_limit`` 1e-6 … 10,
``rotation_resolution`` 1e-7 … 1, at most the limit and at most ``MAX_STEPS`` steps in it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from setupfix.model.process import WKS_COMPONENTS, Feature, Register
from setupfix.model.validate import MAX_WEIGHT, Problems, Ranges, is_number, number, show, table_of, weights

__all__ = [
    "AXIS_NAMES",
    "MULTI_KEYS",
    "ROTATION_RANGES",
    "DIRECTION_TOLERANCE",
    "AxesSettings",
    "parse_axes",
    "expand_registers",
    "feature_relations",
    "check_rotation_positions",
    "dimension_geometry",
    "unit_vector",
]

AXIS_NAMES: tuple[str, ...] = ("X", "Y", "Z")
#: Keys a table may hold only in a multi-axis model.
MULTI_KEYS: dict[str, frozenset[str]] = {
    "process": frozenset({"axes", "spindle", "rotation", "rotation_limit", "rotation_resolution"}),
    "wks": frozenset({"axes", "rotation"}),
    "tools": frozenset({"radius", "radius_limit"}),
    "features": frozenset({"radius"}),
    "dimensions": frozenset({"axis", "direction", "kind", "components", "axes", "diameter"}),
}
#: Allowed ranges of the rotation keys [degrees].
ROTATION_RANGES: dict[str, tuple[float, float]] = {"rotation_limit": (1e-6, 10.0), "rotation_resolution": (1e-7, 1.0)}
#: A ``direction`` is refused when its length differs from 1 by more than this (it is then normalised).
DIRECTION_TOLERANCE = 1e-3
_MAX_STEPS = 100_000


@dataclass(frozen=True)
class AxesSettings:
    """The multi-axis keys of ``[process]``: translation axes, spindle, rotation (degrees)."""

    axes: tuple[str, ...]
    spindle: str = "Z"
    rotation: bool = False
    rotation_limit: float = 0.05
    rotation_resolution: float = 0.0001


def unit_vector(axis: str) -> tuple[float, float, float]:
    """The unit vector of ``"X"``, ``"Y"`` or ``"Z"``."""
    return (float(axis == "X"), float(axis == "Y"), float(axis == "Z"))


def _axis_list(
    p: Problems, key: str, value: Any, allowed: tuple[str, ...], size: int | None = None
) -> tuple[str, ...] | None:
    if (
        not isinstance(value, list)
        or not value
        or not all(isinstance(a, str) and a in allowed for a in value)
        or len(set(value)) != len(value)
        or (size is not None and len(value) != size)
    ):
        count = f"{size} distinct" if size is not None else "distinct"
        p.add(key, f"expected a list of {count} axes of {', '.join(repr(a) for a in allowed)}, found {show(value)}")
        return None
    return tuple(str(a) for a in value)


def _flag(p: Problems, key: str, table: Mapping[str, Any], name: str) -> bool | None:
    value = table.get(name)
    if value is None:
        return None
    if not isinstance(value, bool):
        p.add(f"{key}.{name}", f"expected true or false, found {show(value)}")
        return None
    return value


def parse_axes(p: Problems, proc: Mapping[str, Any]) -> AxesSettings:
    """The ``[process]`` keys ``axes``, ``spindle``, ``rotation``, ``rotation_limit``, ``rotation_resolution``."""
    axes = _axis_list(p, "process.axes", proc.get("axes"), AXIS_NAMES) or ("Z",)
    spindle = proc.get("spindle", "Z")
    if spindle not in AXIS_NAMES:
        p.add("process.spindle", f'expected "X", "Y" or "Z", found {show(spindle)}')
        spindle = "Z"
    rotation = _flag(p, "process", proc, "rotation") or False
    values = {}
    for name, default in (("rotation_limit", 0.05), ("rotation_resolution", 0.0001)):
        got = number(
            p, f"process.{name}", proc.get(name, default), positive=True, within=ROTATION_RANGES[name], unit=" degrees"
        )
        values[name] = got if got is not None else default
    lim, res = values["rotation_limit"], values["rotation_resolution"]
    if res > lim:
        p.add(
            "process.rotation_resolution",
            f"rotation resolution {res:g} degrees is above the rotation limit "
            f"{lim:g} degrees: no rotation could be corrected",
        )
    elif lim / res > _MAX_STEPS:
        p.add(
            "process.rotation_limit",
            f"rotation limit {lim:g} degrees spans {lim / res:.3g} steps of the "
            f"rotation resolution {res:g}; at most {_MAX_STEPS:,} are allowed",
        )
    ordered = tuple(a for a in AXIS_NAMES if a in axes)
    return AxesSettings(ordered, str(spindle), rotation, lim, res)


def expand_registers(
    p: Problems,
    doc: Mapping[str, Any],
    wks: list[Register],
    tools: list[Register],
    settings: AxesSettings,
    ranges: Ranges,
) -> tuple[list[Register], list[Register]]:
    """One register per component: WKS translations (and rotation), tool lengths (and radius).

    ``wks`` and ``tools`` are the loader's one-per-table registers (limit, fixed, policy read);
    the tables' own ``axes``, ``rotation``, ``radius`` and ``radius_limit`` are read here.
    """
    out_wks: list[Register] = []
    wks_tables = table_of(p, "wks", doc.get("wks", {}))
    for reg in wks:
        key = f"wks.{reg.id}"
        table = wks_tables.get(reg.id, {})
        table = table if isinstance(table, Mapping) else {}
        own = settings.axes
        if "axes" in table:
            own = _axis_list(p, f"{key}.axes", table["axes"], settings.axes) or settings.axes
            own = tuple(a for a in AXIS_NAMES if a in own)
        rotation = _flag(p, key, table, "rotation")
        for axis in own:
            out_wks.append(dataclasses.replace(reg, id=f"{reg.id}.{axis}", component=axis, owner=reg.id))
        if rotation if rotation is not None else settings.rotation:
            out_wks.append(
                dataclasses.replace(reg, id=f"{reg.id}.C", component="C", owner=reg.id, limit=settings.rotation_limit)
            )
    out_tools: list[Register] = []
    tool_tables = table_of(p, "tools", doc.get("tools", {}))
    for reg in tools:
        key = f"tools.{reg.id}"
        table = tool_tables.get(reg.id, {})
        table = table if isinstance(table, Mapping) else {}
        out_tools.append(dataclasses.replace(reg, component=settings.spindle, owner=reg.id))
        if "radius_limit" in table and "radius" not in table:
            p.add(f"{key}.radius_limit", 'a radius limit without a radius register (radius = "D…")')
        if "radius" not in table:
            continue
        name = table["radius"]
        if not isinstance(name, str) or not name.strip() or any(ord(c) < 32 for c in name):
            p.add(f"{key}.radius", f'expected a register name (e.g. "D5"), found {show(name)}')
            continue
        limit = reg.limit
        if "radius_limit" in table:
            got = number(
                p,
                f"{key}.radius_limit",
                table["radius_limit"],
                positive=True,
                within=ranges.of["limit"],
                unit=ranges.unit,
            )
            limit = got if got is not None else limit
        out_tools.append(
            dataclasses.replace(reg, id=f"{reg.id}.R", register=name.strip(), component="R", owner=reg.id, limit=limit)
        )
    return out_wks, out_tools


def feature_relations(
    p: Problems,
    key: str,
    table: Mapping[str, Any],
    wks_ids: Mapping[str, Any],
    tool_ids: Mapping[str, Any],
    radius_ids: Collection[str],
) -> tuple[dict[str, dict[str, float]], dict[str, float], dict[str, float]]:
    """A feature's ``wks`` (number or ``{x, y, z, c}`` per WKS), ``tools`` (length) and ``radius`` weights.

    Returns
    -------
    components : dict WKS ID → {"x", "y", "z", "c"} weights (a number fills all four)
    tools : dict tool ID → length weight
    radius : dict tool ID → radius weight ρ_fT
    """
    components: dict[str, dict[str, float]] = {}
    for ref, raw in table_of(p, f"{key}.wks", table.get("wks", {})).items():
        where = f"{key}.wks.{ref}"
        if ref not in wks_ids:
            p.add(where, f"unknown WKS {ref!r}")
            continue
        if isinstance(raw, Mapping):
            comp: dict[str, float] = {}
            for name, value in raw.items():
                if name not in WKS_COMPONENTS:
                    p.add(f"{where}.{name}", f"unknown component (expected one of: {', '.join(WKS_COMPONENTS)})")
                    continue
                w = number(p, f"{where}.{name}", value, within=(-MAX_WEIGHT, MAX_WEIGHT))
                if w is not None and w != 0.0:
                    comp[name] = w
            if comp:
                components[ref] = comp
        else:
            w = number(p, where, raw, within=(-MAX_WEIGHT, MAX_WEIGHT))
            if w is not None and w != 0.0:
                components[ref] = {name: w for name in WKS_COMPONENTS}
    length = weights(p, f"{key}.tools", table.get("tools", {}), tool_ids, "tool")
    radius = {}
    for ref, w in weights(p, f"{key}.radius", table.get("radius", {}), tool_ids, "tool").items():
        if ref not in radius_ids:
            p.add(f"{key}.radius.{ref}", f'tool {ref} has no radius register (add radius = "D…" to [tools.{ref}])')
            continue
        radius[ref] = w
    return components, length, radius


def check_rotation_positions(p: Problems, features: list[Feature], rotating: set[str]) -> None:
    """Refuse a feature a WKS rotation moves (``c`` weight ≠ 0 of a rotating WKS) without ``position``."""
    for feat in features:
        turned = sorted(w for w, comp in feat.components.items() if w in rotating and comp.get("c", 0.0) != 0.0)
        if turned and feat.position is None:
            p.add(
                f"features.{feat.id}.position",
                f"missing: the rotation of {', '.join(turned)} moves this feature by s × position (give its "
                "nominal [x, y, z] in the WKS frame, or c = 0 in its wks weights)",
            )


@dataclass(frozen=True)
class Geometry:
    """A dimension's multi-axis keys, read: kind, measuring direction, zone components, plane and diameter."""

    kind: str = "length"
    direction: tuple[float, float, float] | None = None
    components: tuple[str, ...] = ()
    plane: tuple[str, ...] = ()
    diameter: float | None = None


def dimension_geometry(p: Problems, key: str, table: Mapping[str, Any], default_axis: str, ranges: Ranges) -> Geometry:
    """The keys ``kind``, ``axis``, ``direction``, ``components``, ``axes``, ``diameter`` of a dimension."""
    kind = table.get("kind", "length")
    if kind not in ("length", "size", "position"):
        p.add(f"{key}.kind", f'expected "size" or "position", found {show(kind)}')
        kind = "length"
    if kind != "position":
        for name in ("components", "axes", "diameter"):
            if name in table:
                p.add(f"{key}.{name}", 'only a position zone (kind = "position") has this key')
    direction = unit_vector(default_axis)
    if "axis" in table:
        if table["axis"] not in AXIS_NAMES:
            p.add(f"{key}.axis", f'expected "X", "Y" or "Z", found {show(table["axis"])}')
        else:
            direction = unit_vector(str(table["axis"]))
    if "direction" in table:
        raw = table["direction"]
        if not isinstance(raw, list) or len(raw) != 3 or not all(is_number(v) for v in raw):
            p.add(f"{key}.direction", f"expected [nx, ny, nz] numbers, found {show(raw)}")
        else:
            length = math.sqrt(sum(float(v) ** 2 for v in raw))
            if abs(length - 1.0) > DIRECTION_TOLERANCE:
                p.add(
                    f"{key}.direction",
                    f"not a unit vector (its length is {length:.6g}; expected 1 within {DIRECTION_TOLERANCE:g})",
                )
            else:
                direction = (float(raw[0]) / length, float(raw[1]) / length, float(raw[2]) / length)
    if kind != "position":
        return Geometry(str(kind), direction)
    for name in ("axis", "direction", "lower", "upper"):
        if name in table:
            p.add(
                f"{key}.{name}",
                "a position zone has no "
                + (
                    "measuring direction (its plane is axes = [a, b])"
                    if name in ("axis", "direction")
                    else "lower/upper limit: its tolerance is the diameter"
                ),
            )
    names = table.get("components")
    components: tuple[str, ...] = ()
    if (
        not isinstance(names, list)
        or len(names) != 2
        or not all(isinstance(n, str) and n.strip() for n in names)
        or names[0].strip() == names[1].strip()
    ):
        found = show(names) if names is not None else "none"
        p.add(
            f"{key}.components",
            f'expected the two report characteristics of the zone, e.g. ["Hole 1 X", "Hole 1 Y"], found {found}',
        )
    else:
        components = (names[0].strip(), names[1].strip())
    plane = _axis_list(p, f"{key}.axes", table.get("axes"), AXIS_NAMES, size=2) if "axes" in table else None
    if "axes" not in table:
        p.add(f"{key}.axes", 'missing: the plane of the zone, e.g. axes = ["X", "Y"]')
    diameter = None
    if "diameter" not in table:
        p.add(f"{key}.diameter", "missing: a position zone needs its diameter")
    else:
        hi = ranges.of["tolerance"][1] * 2
        diameter = number(p, f"{key}.diameter", table["diameter"], positive=True, within=(0.0, hi), unit=ranges.unit)
    return Geometry("position", None, components, plane or (), diameter)
