"""The readers of a model file's register and dimension tables, and the keys each table accepts.

Used by :mod:`setupfix.model.loader`, which assembles the model: :func:`register_rows` reads ``[wks.*]`` and
``[tools.*]``, :func:`dimension_rows` reads ``[dimensions.*]``, :func:`check_keys` refuses a key a table does
not take (``TABLE_KEYS``, with the free-text keys every table may hold), and :func:`check_resolution` checks the
resolution against the limits and the tolerance bands.  Every problem goes to the
:class:`~setupfix.model.validate.Problems` of the file, with its key path.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from setupfix.model import axes as multi_axis
from setupfix.model.process import Dimension, Feature, Register, RegisterKind
from setupfix.model.safety import REGISTER_KEYS, parse_register_policy
from setupfix.model.validate import Problems, Ranges, control_free, number, section_of, show, table_of, weights

__all__ = [
    "MAX_STEPS",
    "FREE_TEXT",
    "TABLE_KEYS",
    "check_keys",
    "register_rows",
    "check_resolution",
    "report_in",
    "dimension_rows",
]

#: Bound on ``limit / resolution``: register steps one correction may span.
MAX_STEPS = 100_000

FREE_TEXT = {"description", "comment", "note", "notes"}
TABLE_KEYS = {
    "process": {"name", "axis", "unit", "resolution", "limit", "draft", "machine"} | FREE_TEXT,
    "machine": {"wks"} | FREE_TEXT,
    "wks": {"register", "limit", "fixed"} | FREE_TEXT,
    "tools": {"register", "limit", "fixed"} | FREE_TEXT,
    "features": {"wks", "tools", "position"} | FREE_TEXT,
    "dimensions": {"name", "aliases", "features", "nominal", "lower", "upper", "group", "sampled"} | FREE_TEXT,
}


def check_keys(p: Problems, section: str, key: str, table: Mapping[str, Any], multi: bool = False) -> None:
    allowed_here = TABLE_KEYS[section] | (set(REGISTER_KEYS) if section in ("wks", "tools") else set())
    extra = multi_axis.MULTI_KEYS.get(section, frozenset())
    if multi:
        allowed_here = allowed_here | extra
    for name in table:
        if name in extra and not multi:
            p.add(f"{key}.{name}", "a multi-axis key: only in a model whose [process] table has axes = [...]")
        elif name not in allowed_here:
            allowed = ", ".join(sorted(allowed_here - FREE_TEXT))
            p.add(f"{key}.{name}", f"unknown key (expected one of: {allowed})")


def register_rows(
    p: Problems,
    doc: dict[str, Any],
    section: str,
    kind: RegisterKind,
    limit: float,
    ranges: Ranges,
    multi: bool = False,
) -> list[Register]:
    regs = []
    for rid, raw in table_of(p, section, doc.get(section, {})).items():
        key = f"{section}.{rid}"
        table = table_of(p, key, raw)
        check_keys(p, section, key, table, multi)
        control_free(p, key, rid, "ID")
        name = table.get("register", rid)
        if not isinstance(name, str) or not name.strip():
            p.add(f"{key}.register", f"expected a register name, found {show(name)}")
            name = rid
        elif "register" in table and not control_free(p, f"{key}.register", name, "register name"):
            name = rid
        lim = (
            number(p, f"{key}.limit", table["limit"], positive=True, within=ranges.of["limit"], unit=ranges.unit)
            if "limit" in table
            else limit
        )
        fixed = table.get("fixed", False)
        if not isinstance(fixed, bool):
            p.add(f"{key}.fixed", f"expected true or false, found {show(fixed)}")
            fixed = False
        policy = parse_register_policy(table, functools.partial(report_in, p, key))
        regs.append(Register(rid, kind, name.strip(), lim if lim is not None else limit, fixed, policy))
    return regs


def check_resolution(
    p: Problems, resolution: float, limit: float, registers: list[Register], dimensions: list[Dimension], unit: str
) -> None:
    """Resolution against the limits (the process's, then each register's own) and the tolerance bands."""
    checks = [("process.limit", limit)] + [
        (f"{section_of(reg)}.{'radius_limit' if reg.component == 'R' else 'limit'}", reg.limit)
        for reg in registers
        if reg.limit != limit and reg.component != "C"
    ]  # a rotation: degrees (axes.py)
    checks = list(dict.fromkeys(checks))
    for key, lim in checks:
        if lim < resolution:
            p.add(
                key,
                f"limit {lim:g} {unit} is below the resolution {resolution:g} {unit}: no correction "
                f"could be made (allowed: at least the resolution; fixed = true holds a register)",
            )
        elif lim / resolution > MAX_STEPS:
            p.add(
                key,
                f"limit {lim:g} {unit} spans {lim / resolution:.3g} steps of the resolution "
                f"{resolution:g} {unit}; at most {MAX_STEPS:,} are allowed",
            )
    bands = [(d.upper - d.lower, d) for d in dimensions if math.isfinite(d.upper - d.lower)]
    if bands:
        width, narrowest = min(bands, key=lambda b: b[0])
        if resolution > width / 2:
            p.add(
                "process.resolution",
                f"resolution {resolution:g} {unit} is coarser than half the narrowest tolerance band "
                f"({narrowest.name}: {width:g} {unit} wide); allowed: at most {width / 2:g} {unit}",
            )


def report_in(p: Problems, section: str, key: str, message: str) -> None:
    p.add(f"{section}.{key}" if key else section, message)


def dimension_rows(
    p: Problems, doc: Mapping[str, Any], feature_ids: Mapping[str, Feature], ranges: Ranges, axis: str | None = None
) -> list[Dimension]:
    """The ``[dimensions.*]`` tables; ``axis`` (the default measuring axis) only in a multi-axis model."""
    multi = axis is not None
    dimensions = []
    # a name answers to one dimension and to at most one zone component: a drawing may tolerance a hole's
    # X both alone (±0.03) and in its position zone (⌀0.1), and one report row then feeds both
    seen_names: dict[tuple[str, str | None, bool], str] = {}
    for did, raw in table_of(p, "dimensions", doc.get("dimensions", {})).items():
        key = f"dimensions.{did}"
        table = table_of(p, key, raw)
        check_keys(p, "dimensions", key, table, multi)
        control_free(p, key, did, "ID")
        geometry = multi_axis.dimension_geometry(p, key, table, axis, ranges) if axis is not None else None
        zone = geometry is not None and geometry.kind == "position"
        dname = table.get("name", did)
        if not isinstance(dname, str) or not dname.strip():
            p.add(f"{key}.name", f"expected a name, found {show(dname)}")
            dname = did
        aliases = table.get("aliases", [])
        if not isinstance(aliases, list) or not all(isinstance(a, str) and a.strip() for a in aliases):
            p.add(f"{key}.aliases", f"expected a list of names, found {show(aliases)}")
            aliases = []
        group = table.get("group")
        if group is not None and not isinstance(group, str):
            p.add(f"{key}.group", f"expected a string, found {show(group)}")
            group = None
        sampled = table.get("sampled", False)  # not measured every cycle (coverage: pose_problem)
        if not isinstance(sampled, bool):
            p.add(f"{key}.sampled", f"expected true or false, found {show(sampled)}")
            sampled = False
        if "features" not in table:
            p.add(f"{key}.features", "missing: which features enter this dimension")
        fd = weights(p, f"{key}.features", table.get("features", {}), feature_ids, "feature")
        values: dict[str, float | None] = {}
        for field_name in ("nominal", "lower", "upper"):
            if zone and (field_name != "nominal" or field_name not in table):
                values[field_name] = 0.0 if field_name == "nominal" else None
            elif field_name not in table:
                what = "nominal value" if field_name == "nominal" else "tolerance limit"
                p.add(f"{key}.{field_name}", f"missing {what}")
                values[field_name] = None
            else:
                within = ranges.of["nominal" if field_name == "nominal" else "tolerance"]
                values[field_name] = number(
                    p, f"{key}.{field_name}", table[field_name], within=within, unit=ranges.unit
                )
        lo, up = values["lower"], values["upper"]
        if geometry is not None and zone:
            lo, up = 0.0, (geometry.diameter or 0.0) / 2 or None
        if lo is not None and up is not None and lo >= up:
            p.add(f"{key}.lower", f"lower limit {lo:g} must be below upper limit {up:g}")
        dim = Dimension(
            id=did,
            name=dname.strip(),
            features=fd,
            nominal=values["nominal"] if values["nominal"] is not None else 0.0,
            lower=lo if lo is not None else -math.inf,
            upper=up if up is not None else math.inf,
            aliases=tuple(a.strip() for a in aliases),
            group=group,
            sampled=sampled,
        )
        if geometry is not None:
            dim = replace(
                dim,
                kind=geometry.kind,
                direction=geometry.direction,
                components=geometry.components,
                plane=geometry.plane,
                diameter=geometry.diameter,
            )
        for k, component in (*((k, False) for k in dim.keys), *((k, True) for k in dim.component_keys)):
            other = seen_names.get((k, group, component))
            if other is not None and other != did:
                p.add(
                    f"{key}.components" if component else f"{key}.name",
                    f"name {k!r} is also "
                    + ("a component of position zone" if component else "used by dimension")
                    + f" {other}"
                    + (f" in group {group!r}" if group else ""),
                )
            seen_names[(k, group, component)] = did
        dimensions.append(dim)
    if not dimensions:
        p.add("dimensions", "the model declares no dimension")
    return dimensions
