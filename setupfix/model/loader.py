"""Load and validate a process model file (``../shared/spec/process-model.md``).

Every problem is collected with its key path before anything is raised, so the
engineer fixes the file in one pass: :class:`~setupfix.core.errors.ModelError` carries
the list in ``problems`` and its text has one line per problem.

Sanity ranges (a correction goes into a machine: an absurd model must not load).
Lengths are given in millimetres and converted to the model unit:

======================  ==========================================================
``resolution``          1e-6 … 1 mm, at most ``limit``, at most half the narrowest
                        tolerance band, and ``limit / resolution`` ≤ 100,000 steps
``limit`` (any)         ≤ 10 mm
``nominal``             |nominal| ≤ 100,000 mm
``lower``, ``upper``    |limit| ≤ 100 mm
weights                 0 < |w| ≤ 1,000
``position``            |coordinate| ≤ 100,000 mm
======================  ==========================================================

Registers: two registers addressing one controller slot (``H5`` and ``H05``, ``G110``
and ``G154 P1``, a ``number`` another register's name gives) are refused, naming both
(:func:`setupfix.model.slots.register_slots`).  IDs (the keys of ``[wks]``, ``[tools]``,
``[features]``, ``[machine]``, ``[dimensions]``) and register names must not hold
control characters (Unicode Cc, Zl, Zp: a newline or escape breaks a table row or a
program line).  Names are free text (the process name, a dimension's ``name``,
``aliases`` and ``group`` match reports whose names may hold anything): they load as
written and every text table escapes them.

Multi-axis models (``[process] axes``, spec *Multi-axis models*): the keys that only they may
hold are read by :mod:`setupfix.model.axes` (registers expanded to components, per-component
feature weights, radius weights, measuring directions, sizes and position zones); in a one-axis
file those keys are refused as multi-axis keys and everything loads exactly as before.  The
shared readers and the problem list are :mod:`setupfix.model.validate`'s; the register and
dimension tables are read by :mod:`setupfix.model.tables`.

Optional tables parsed into typed fields: ``[safety]`` (:func:`setupfix.model.safety.parse_safety`
→ ``ProcessModel.safety``), ``[effects]`` (:func:`setupfix.model.effects.parse_effects` →
``ProcessModel.effects``) and the per-register keys of ``[wks.*]`` / ``[tools.*]``
(:func:`setupfix.model.safety.parse_register_policy` → ``Register.policy``).  The measurement
uncertainty of ``[measurement]`` (:func:`setupfix.model.safety.parse_measurement`) and of each
``[dimensions.ID] uncertainty`` is folded into ``ProcessModel.safety`` with where each value comes
from (:func:`setupfix.model.safety.with_measurement`).
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from setupfix.core.errors import ModelError, SourceLocation
from setupfix.core.units import LENGTH_UNITS
from setupfix.model import axes as multi_axis
from setupfix.model.effects import parse_effects
from setupfix.model.process import Feature, MachinePoint, ProcessModel
from setupfix.model.safety import (
    MeasurementSettings,
    guard_band_problems,
    parse_measurement,
    parse_safety,
    with_measurement,
)
from setupfix.model.stations import expand_stations
from setupfix.model.tables import TABLE_KEYS, check_keys, check_resolution, dimension_rows, register_rows, report_in
from setupfix.model.validate import (
    RANGES_MM,
    Problems,
    Ranges,
    check_slots,
    control_free,
    is_number,
    number,
    show,
    table_of,
    weights,
)

__all__ = [
    "SECTIONS",
    "RANGES_MM",
    "load_model",
    "model_from_dict",
]

#: Optional top-level tables, each parsed into a typed field of the model (module docstring).
SECTIONS: tuple[str, ...] = ("effects", "safety", "measurement")
#: A model file larger than this is refused before parsing.
MAX_BYTES = 16 * 1024 * 1024
#: Top-level tables consumed before validation (station templates, see ``stations``).
EXPANDED_SECTIONS = {"stations", "template"}


def model_from_dict(doc: Mapping[str, Any], source: str = "<model>", text: str | None = None) -> ProcessModel:
    """Validate a parsed model document and build the :class:`ProcessModel`.

    ``text``, the document as written, lets every problem name its line too.

    Raises
    ------
    ModelError
        With one line per problem, each naming ``source`` and the key path.
    """
    expanded, origin, template_problems = expand_stations(doc)
    p = Problems(source, origin, text)
    for key, message in template_problems:
        p.add(key, message)
    doc = expanded
    for top in doc:
        if top not in TABLE_KEYS and top not in SECTIONS and top not in EXPANDED_SECTIONS:
            known = [*TABLE_KEYS, *SECTIONS, *sorted(EXPANDED_SECTIONS)]
            p.add(top, f"unknown table (expected one of: {', '.join(known)})")
    if "process" not in doc:
        p.add("process", "missing required table [process]")
    proc = table_of(p, "process", doc.get("process", {}))
    multi = "axes" in proc
    check_keys(p, "process", "process", proc, multi)
    name = proc.get("name")
    if "process" in doc and (not isinstance(name, str) or not name.strip()):
        p.add("process.name", "missing required process name")
    axis = proc.get("axis", "Z")
    if axis not in ("X", "Y", "Z"):
        p.add("process.axis", f'expected "X", "Y" or "Z", found {show(axis)}')
    unit = proc.get("unit", "mm")
    if not isinstance(unit, str) or LENGTH_UNITS.get(unit.strip().lower()) is None:
        p.add("process.unit", f'unknown unit {show(unit)} (expected "mm" or "inch")')
        unit = "mm"
    unit = LENGTH_UNITS[unit.strip().lower()]
    ranges = Ranges(unit)
    resolution = number(
        p,
        "process.resolution",
        proc.get("resolution", 0.001),
        positive=True,
        within=ranges.of["resolution"],
        unit=ranges.unit,
    )
    limit = number(
        p, "process.limit", proc.get("limit", 0.1), positive=True, within=ranges.of["limit"], unit=ranges.unit
    )

    draft = proc.get("draft", False)
    if not isinstance(draft, bool):
        p.add("process.draft", f"expected true or false, found {show(draft)}")
        draft = False
    machine = proc.get("machine")
    if machine is not None and (not isinstance(machine, str) or not machine.strip()):
        p.add("process.machine", f"expected a machine name, found {show(machine)}")
        machine = None
    elif machine is not None and not control_free(p, "process.machine", machine, "machine name"):
        machine = None

    settings = multi_axis.parse_axes(p, proc) if multi else None
    wks = register_rows(p, doc, "wks", "wks", limit or 0.1, ranges, multi)
    tools = register_rows(p, doc, "tools", "tool", limit or 0.1, ranges, multi)
    wks_ids = {r.id: r for r in wks}
    tool_ids = {r.id: r for r in tools}
    for rid in wks_ids.keys() & tool_ids.keys():
        p.add(f"tools.{rid}", f"ID {rid!r} is declared both as a WKS and as a tool")
    if settings is not None:
        wks, tools = multi_axis.expand_registers(p, doc, wks, tools, settings, ranges)
        if doc.get("machine"):
            p.add("machine", "machine points are not supported in a multi-axis model (correct the WKS directly)")
    radius_ids = {r.base for r in tools if r.component == "R"}
    check_slots(p, [*wks, *tools])
    if not wks and not tools:
        p.add("wks", "the model declares no WKS and no tool: nothing to correct")

    machines = []
    for mid, raw in table_of(p, "machine", doc.get("machine", {})).items():
        table = table_of(p, f"machine.{mid}", raw)
        control_free(p, f"machine.{mid}", mid, "ID")
        check_keys(p, "machine", f"machine.{mid}", table)
        machines.append(MachinePoint(mid, weights(p, f"machine.{mid}.wks", table.get("wks", {}), wks_ids, "WKS")))

    features = []
    for fid, raw in table_of(p, "features", doc.get("features", {})).items():
        key = f"features.{fid}"
        table = table_of(p, key, raw)
        control_free(p, key, fid, "ID")
        check_keys(p, "features", key, table, multi)
        fw: dict[str, float] = {}
        components: dict[str, dict[str, float]] = {}
        radius: dict[str, float] = {}
        if multi:
            components, ft, radius = multi_axis.feature_relations(p, key, table, wks_ids, tool_ids, radius_ids)
        else:
            fw = weights(p, f"{key}.wks", table.get("wks", {}), wks_ids, "WKS")
            ft = weights(p, f"{key}.tools", table.get("tools", {}), tool_ids, "tool")
        pos = table.get("position")
        position = None
        if pos is not None:
            lo, hi = ranges.of["position"]
            if isinstance(pos, list) and len(pos) == 3 and all(is_number(v) and lo <= v <= hi for v in pos):
                position = (float(pos[0]), float(pos[1]), float(pos[2]))
            else:
                p.add(
                    f"{key}.position",
                    f"expected [x, y, z] numbers within [{lo:g}, {hi:g}]{ranges.unit}, found {show(pos)}",
                )
        features.append(Feature(fid, fw, ft, position, components, radius))
    feature_ids = {f.id: f for f in features}
    if not features:
        p.add("features", "the model declares no feature")
    if multi:
        multi_axis.check_rotation_positions(p, features, {r.base for r in wks if r.component == "C"})

    doc, own_u = _dimension_uncertainty(p, doc)
    dimensions = dimension_rows(p, doc, feature_ids, ranges, str(axis) if multi else None)
    if resolution is not None and not p.items:
        check_resolution(p, resolution, limit or 0.1, [*wks, *tools], dimensions, unit)
    p.raise_if_any()
    assert resolution is not None and limit is not None  # refused above otherwise
    model = ProcessModel(
        name=str(name).strip(),
        axis=str(axis),
        unit=unit,
        resolution=resolution,
        limit=limit,
        wks=tuple(wks),
        tools=tuple(tools),
        machines=tuple(machines),
        features=tuple(features),
        dimensions=tuple(dimensions),
        source=source,
        axes=settings.axes if settings is not None else (),
        spindle=settings.spindle if settings is not None else str(axis),
        draft=draft,
        machine=machine.strip() if machine else None,
        rotation_limit=settings.rotation_limit if settings is not None else 0.05,
        rotation_resolution=settings.rotation_resolution if settings is not None else 0.0001,
    )
    if "effects" in doc:
        effects = parse_effects(doc["effects"], model, functools.partial(report_in, p, "effects"))
        model = replace(model, effects=effects)
    if "safety" in doc:
        model = replace(
            model, safety=parse_safety(doc["safety"], model.dimension_ids, functools.partial(report_in, p, "safety"))
        )
    measurement = (
        parse_measurement(doc["measurement"], functools.partial(report_in, p, "measurement"))
        if "measurement" in doc
        else MeasurementSettings()
    )
    if "measurement" in doc or own_u:
        safety = with_measurement(model.safety, measurement, own_u, model.dimensions, model.unit, p.add)
        model = replace(model, safety=safety)
    if "safety" in doc or "measurement" in doc or own_u:
        for key, message in guard_band_problems(model.safety, model.dimensions):
            report_in(p, "safety", key, message)
    p.raise_if_any()
    return model


def _dimension_uncertainty(p: Problems, doc: Mapping[str, Any]) -> tuple[Mapping[str, Any], dict[str, float]]:
    """The ``[dimensions.ID] uncertainty`` values (U, k = 2, model unit), and the document without them.

    The key is taken out of each dimension's table before the tables are read, so the
    dimension rows keep their own key checks; a bad value is reported at its key path.
    """
    dims = doc.get("dimensions")
    if not isinstance(dims, Mapping) or not any(isinstance(t, Mapping) and "uncertainty" in t for t in dims.values()):
        return doc, {}
    own: dict[str, float] = {}
    stripped: dict[str, Any] = {}
    for did, table in dims.items():
        if isinstance(table, Mapping) and "uncertainty" in table:
            value = table["uncertainty"]
            if is_number(value) and math.isfinite(value) and value >= 0:
                own[str(did)] = float(value)
            else:
                p.add(f"dimensions.{did}.uncertainty", f"expected a number ≥ 0 (U, k = 2), found {show(value)}")
            table = {k: v for k, v in table.items() if k != "uncertainty"}
        stripped[did] = table
    return {**doc, "dimensions": stripped}, own


def load_model(path: str | Path) -> ProcessModel:
    """Read and validate a process model TOML file.

    Raises
    ------
    ModelError
        If the file is missing, not TOML, or breaks the contract; the message names
        the file and the line (syntax) or key path (content) of every problem.
    """
    path = Path(path)
    where = SourceLocation(str(path))
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ModelError(f"cannot read model: {exc.strerror}", location=where) from None
    if len(raw) > MAX_BYTES:
        raise ModelError(f"larger than {MAX_BYTES // 2**20} MiB: not a process model", location=where)
    try:
        text = raw.decode("utf-8-sig")
        doc = tomllib.loads(text)
    except UnicodeDecodeError as exc:
        raise ModelError(f"not UTF-8 text (byte {exc.start})", location=where) from None
    except tomllib.TOMLDecodeError as exc:
        # Python 3.11 puts the position only in the text: "… (at line 3, column 7)".
        found = re.search(r"\(at line (\d+), column \d+\)|\(at end of document\)", str(exc))
        msg = str(exc).replace(found.group(0), "").strip() if found else str(exc)
        line = int(found.group(1)) if found and found.group(1) else raw.count(b"\n") + 1 if found else None
        raise ModelError(f"TOML syntax: {msg}", location=SourceLocation(str(path), line=line)) from None
    except RecursionError:
        raise ModelError("TOML nested too deeply (arrays or inline tables inside each other)", location=where) from None
    except ValueError as exc:  # an integer beyond Python's int/str conversion limit
        raise ModelError(f"TOML value out of range: {exc}", location=where) from None
    return model_from_dict(doc, source=str(path), text=text)
