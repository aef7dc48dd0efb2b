"""Load and validate a process model file (``../shared/spec/process-model.md``).

Every problem is collected with its key path before anything is raised, so the
engineer fixes the file in one pass: :class:`~setupfix.errors.ModelError` carries
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

Optional tables parsed into typed fields: ``[safety]`` (:func:`setupfix.model.safety.parse_safety`
→ ``ProcessModel.safety``), ``[effects]`` (:func:`setupfix.model.effects.parse_effects` →
``ProcessModel.effects``) and the per-register keys of ``[wks.*]`` / ``[tools.*]``
(:func:`setupfix.model.safety.parse_register_policy` → ``Register.policy``).
"""

from __future__ import annotations

import functools
import math
import re
import sys
import tomllib
import unicodedata
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from setupfix.errors import ModelError, SourceLocation
from setupfix.model.effects import parse_effects
from setupfix.model.process import (
    Dimension,
    Feature,
    MachinePoint,
    ProcessModel,
    Register,
    RegisterKind,
)
from setupfix.model.safety import REGISTER_KEYS, parse_register_policy, parse_safety
from setupfix.model.slots import register_slots
from setupfix.model.stations import expand_stations
from setupfix.units import LENGTH_UNITS, length_factor

__all__ = [
    "SECTIONS",
    "RANGES_MM",
    "MAX_STEPS",
    "load_model",
    "model_from_dict",
]

#: Optional top-level tables, each parsed into a typed field of the model (module docstring).
SECTIONS: tuple[str, ...] = ("effects", "safety")

#: Allowed ranges of lengths [mm], converted to the model unit when checked.
RANGES_MM: dict[str, tuple[float, float]] = {
    "resolution": (1e-6, 1.0),
    "limit": (1e-6, 10.0),
    "nominal": (-1e5, 1e5),
    "tolerance": (-100.0, 100.0),
    "position": (-1e5, 1e5),
}
#: Bound on ``limit / resolution``: register steps one correction may span.
MAX_STEPS = 100_000
#: Bound on the absolute value of a relation weight.
MAX_WEIGHT = 1000.0
#: A model file larger than this is refused before parsing.
MAX_BYTES = 16 * 1024 * 1024

_FREE_TEXT = {"description", "comment", "note", "notes"}
_KEYS = {
    "process": {"name", "axis", "unit", "resolution", "limit", "draft"} | _FREE_TEXT,
    "machine": {"wks"} | _FREE_TEXT,
    "wks": {"register", "limit", "fixed"} | _FREE_TEXT,
    "tools": {"register", "limit", "fixed"} | _FREE_TEXT,
    "features": {"wks", "tools", "position"} | _FREE_TEXT,
    "dimensions": {"name", "aliases", "features", "nominal", "lower", "upper", "group", "sampled"} | _FREE_TEXT,
}
#: Top-level tables consumed before validation (station templates, see ``stations``).
_EXPANDED = {"stations", "template"}


_HEADER = re.compile(r"^\s*\[\[?\s*([^\[\]]+?)\s*\]\]?\s*(?:#.*)?$")
_ASSIGN = re.compile(r"""^\s*["']?([^"'=\s]+)["']?\s*=""")


class _Lines:
    """Line of a key path in the model's text: its own ``key =`` line, else its table's header.

    Enough for the files people write (``[wks.W5]`` then ``register = …``); a key it
    cannot place gets no line, only its key path.
    """

    def __init__(self, text: str | None) -> None:
        self.tables: dict[str, int] = {}
        self.assigned: dict[str, int] = {}
        table = ""
        for number, line in enumerate((text or "").splitlines(), 1):
            header = _HEADER.match(line)
            if header:
                table = ".".join(part.strip().strip("\"'") for part in header.group(1).split("."))
                self.tables.setdefault(table, number)
                continue
            assign = _ASSIGN.match(line)
            if assign:
                self.assigned.setdefault(f"{table}.{assign.group(1)}" if table else assign.group(1), number)

    def __call__(self, key: str) -> int | None:
        parts = key.split(".")
        for n in range(len(parts), 0, -1):
            head = ".".join(parts[:n])
            if head in self.assigned:
                return self.assigned[head]
            if head in self.tables:
                return self.tables[head]
        return None


class _Problems:
    """Collects problems with their key paths (and lines, when the text is known)."""

    def __init__(self, path: str, origin: Mapping[str, str] | None = None, text: str | None = None) -> None:
        self.path = path
        self.origin = origin or {}
        self.items: list[ModelError] = []
        self.line_of = _Lines(text)

    def add(self, key: str, message: str) -> None:
        where = self._where(key)
        self.items.append(ModelError(message, location=SourceLocation(self.path, line=self.line_of(where),
                                                                      key=where)))

    def _where(self, key: str) -> str:
        """Key path in the file as written (templated tables name their template and station)."""
        parts = key.split(".")
        for n in range(min(len(parts), 2), 1, -1):
            head = ".".join(parts[:n])
            if head in self.origin:
                return ".".join([self.origin[head], *parts[n:]])
        return key

    def raise_if_any(self) -> None:
        if self.items:
            text = "\n".join(str(p) for p in self.items)
            err = ModelError(text)
            err.problems = tuple(self.items)
            raise err


def _show(value: Any) -> str:
    """A value for a message: short, never failing (huge integers, deep tables)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return f"an integer of {len(str(abs(value))) if value.bit_length() < 13000 else 'thousands of'} digits"
    if isinstance(value, (dict, list)):
        return f"a {'table' if isinstance(value, dict) else 'list'}"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_number(value: Any) -> bool:
    """A finite TOML number that fits a float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if isinstance(value, int):
        return abs(value) <= sys.float_info.max
    return math.isfinite(value)


def _number(p: _Problems, key: str, value: Any, *, positive: bool = False,
            within: tuple[float, float] | None = None, unit: str = "") -> float | None:
    if not _is_number(value):
        why = "not finite or beyond the float range" if isinstance(value, (int, float)) and not isinstance(
            value, bool) else "expected a number"
        p.add(key, f"{why}, found {_show(value)}")
        return None
    number = float(value)
    if positive and number <= 0:
        p.add(key, f"must be > 0, found {_show(value)}")
        return None
    if within is not None and not within[0] <= number <= within[1]:
        p.add(key, f"{number:g}{unit} is outside the allowed range [{within[0]:g}, {within[1]:g}]{unit}")
        return None
    return number


def _control_free(p: _Problems, key: str, text: str, what: str) -> bool:
    """An ID (table key, register name): no control character (a table row, a program line would break).

    Control characters are Unicode categories Cc (tab, newline, escape …), Zl and Zp
    (line and paragraph separators); other blanks (no-break space) are kept.
    """
    bad = next((c for c in text if unicodedata.category(c) in ("Cc", "Zl", "Zp")), None)
    if bad is None:
        return True
    p.add(key, f"{what} {text!r} holds the control character U+{ord(bad):04X}; IDs and names are one "
               "line of printable text")
    return False


def _table(p: _Problems, key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        p.add(key, f"expected a table, found {type(value).__name__}")
        return {}
    return dict(value)


def _check_keys(p: _Problems, section: str, key: str, table: Mapping[str, Any]) -> None:
    allowed_here = _KEYS[section] | (set(REGISTER_KEYS) if section in ("wks", "tools") else set())
    for name in table:
        if name not in allowed_here:
            allowed = ", ".join(sorted(allowed_here - _FREE_TEXT))
            p.add(f"{key}.{name}", f"unknown key (expected one of: {allowed})")


def _weights(p: _Problems, key: str, value: Any, known: Mapping[str, Any], what: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for ref, weight in _table(p, key, value).items():
        if ref not in known:
            p.add(f"{key}.{ref}", f"unknown {what} {ref!r}")
            continue
        w = _number(p, f"{key}.{ref}", weight, within=(-MAX_WEIGHT, MAX_WEIGHT))
        if w is not None and w != 0.0:
            out[ref] = w
    return out


class _Ranges:
    """The sanity ranges converted to the model unit."""

    def __init__(self, unit: str) -> None:
        f = length_factor("mm", unit)
        self.unit = f" {unit}"
        self.of = {name: (lo * f, hi * f) for name, (lo, hi) in RANGES_MM.items()}


def _registers(p: _Problems, doc: dict[str, Any], section: str, kind: RegisterKind, limit: float,
               ranges: _Ranges) -> list[Register]:
    regs = []
    for rid, raw in _table(p, section, doc.get(section, {})).items():
        key = f"{section}.{rid}"
        table = _table(p, key, raw)
        _check_keys(p, section, key, table)
        _control_free(p, key, rid, "ID")
        name = table.get("register", rid)
        if not isinstance(name, str) or not name.strip():
            p.add(f"{key}.register", f"expected a register name, found {_show(name)}")
            name = rid
        elif "register" in table and not _control_free(p, f"{key}.register", name, "register name"):
            name = rid
        lim = (_number(p, f"{key}.limit", table["limit"], positive=True, within=ranges.of["limit"],
                       unit=ranges.unit) if "limit" in table else limit)
        fixed = table.get("fixed", False)
        if not isinstance(fixed, bool):
            p.add(f"{key}.fixed", f"expected true or false, found {_show(fixed)}")
            fixed = False
        policy = parse_register_policy(table, functools.partial(_report_in, p, key))
        regs.append(Register(rid, kind, name.strip(), lim if lim is not None else limit, fixed, policy))
    return regs


def _section(reg: Register) -> str:
    return f"{'wks' if reg.kind == 'wks' else 'tools'}.{reg.id}"


def _check_slots(p: _Problems, registers: list[Register]) -> None:
    """Two registers addressing one controller slot (``H5``/``H05``, ``G110``/``G154 P1``, ``number``)."""
    owner: dict[str, Register] = {}
    for reg in registers:
        for slot in sorted(register_slots(reg.kind, reg.register, reg.policy.number, reg.policy.edge)):
            first = owner.setdefault(slot, reg)
            if first is not reg:
                line = p.line_of(p._where(f"{_section(first)}.register"))
                p.add(f"{_section(reg)}.register",
                      f"register {reg.register!r} addresses the controller slot {slot}, also used by "
                      f"{first.id} ([{_section(first)}]{f' line {line}' if line else ''}, register {first.register!r}"
                      + (f", number = {first.policy.number}" if first.policy.number is not None else "")
                      + "): a program would write both corrections to one offset")
                break


def _check_resolution(p: _Problems, resolution: float, limit: float, registers: list[Register],
                      dimensions: list[Dimension], unit: str) -> None:
    """Resolution against the limits (the process's, then each register's own) and the tolerance bands."""
    checks = [("process.limit", limit)] + [
        (f"{'wks' if reg.kind == 'wks' else 'tools'}.{reg.id}.limit", reg.limit)
        for reg in registers if reg.limit != limit]
    for key, lim in checks:
        if lim < resolution:
            p.add(key, f"limit {lim:g} {unit} is below the resolution {resolution:g} {unit}: no correction "
                       f"could be made (allowed: at least the resolution; fixed = true holds a register)")
        elif lim / resolution > MAX_STEPS:
            p.add(key, f"limit {lim:g} {unit} spans {lim / resolution:.3g} steps of the resolution "
                       f"{resolution:g} {unit}; at most {MAX_STEPS:,} are allowed")
    bands = [(d.upper - d.lower, d) for d in dimensions if math.isfinite(d.upper - d.lower)]
    if bands:
        width, narrowest = min(bands, key=lambda b: b[0])
        if resolution > width / 2:
            p.add("process.resolution",
                  f"resolution {resolution:g} {unit} is coarser than half the narrowest tolerance band "
                  f"({narrowest.name}: {width:g} {unit} wide); allowed: at most {width / 2:g} {unit}")


def model_from_dict(doc: Mapping[str, Any], source: str = "<model>", text: str | None = None) -> ProcessModel:
    """Validate a parsed model document and build the :class:`ProcessModel`.

    ``text``, the document as written, lets every problem name its line too.

    Raises
    ------
    ModelError
        With one line per problem, each naming ``source`` and the key path.
    """
    expanded, origin, template_problems = expand_stations(doc)
    p = _Problems(source, origin, text)
    for key, message in template_problems:
        p.add(key, message)
    doc = expanded
    for top in doc:
        if top not in _KEYS and top not in SECTIONS and top not in _EXPANDED:
            known = [*_KEYS, *SECTIONS, *sorted(_EXPANDED)]
            p.add(top, f"unknown table (expected one of: {', '.join(known)})")
    if "process" not in doc:
        p.add("process", "missing required table [process]")
    proc = _table(p, "process", doc.get("process", {}))
    _check_keys(p, "process", "process", proc)
    name = proc.get("name")
    if "process" in doc and (not isinstance(name, str) or not name.strip()):
        p.add("process.name", "missing required process name")
    axis = proc.get("axis", "Z")
    if axis not in ("X", "Y", "Z"):
        p.add("process.axis", f'expected "X", "Y" or "Z", found {_show(axis)}')
    unit = proc.get("unit", "mm")
    if not isinstance(unit, str) or LENGTH_UNITS.get(unit.strip().lower()) is None:
        p.add("process.unit", f'unknown unit {_show(unit)} (expected "mm" or "inch")')
        unit = "mm"
    unit = LENGTH_UNITS[unit.strip().lower()]
    ranges = _Ranges(unit)
    resolution = _number(p, "process.resolution", proc.get("resolution", 0.001), positive=True,
                         within=ranges.of["resolution"], unit=ranges.unit)
    limit = _number(p, "process.limit", proc.get("limit", 0.1), positive=True, within=ranges.of["limit"],
                    unit=ranges.unit)

    draft = proc.get("draft", False)
    if not isinstance(draft, bool):
        p.add("process.draft", f"expected true or false, found {_show(draft)}")
        draft = False

    wks = _registers(p, doc, "wks", "wks", limit or 0.1, ranges)
    tools = _registers(p, doc, "tools", "tool", limit or 0.1, ranges)
    wks_ids = {r.id: r for r in wks}
    tool_ids = {r.id: r for r in tools}
    for rid in wks_ids.keys() & tool_ids.keys():
        p.add(f"tools.{rid}", f"ID {rid!r} is declared both as a WKS and as a tool")
    _check_slots(p, [*wks, *tools])
    if not wks and not tools:
        p.add("wks", "the model declares no WKS and no tool: nothing to correct")

    machines = []
    for mid, raw in _table(p, "machine", doc.get("machine", {})).items():
        table = _table(p, f"machine.{mid}", raw)
        _control_free(p, f"machine.{mid}", mid, "ID")
        _check_keys(p, "machine", f"machine.{mid}", table)
        machines.append(MachinePoint(mid, _weights(p, f"machine.{mid}.wks", table.get("wks", {}), wks_ids, "WKS")))

    features = []
    for fid, raw in _table(p, "features", doc.get("features", {})).items():
        key = f"features.{fid}"
        table = _table(p, key, raw)
        _control_free(p, key, fid, "ID")
        _check_keys(p, "features", key, table)
        fw = _weights(p, f"{key}.wks", table.get("wks", {}), wks_ids, "WKS")
        ft = _weights(p, f"{key}.tools", table.get("tools", {}), tool_ids, "tool")
        pos = table.get("position")
        position = None
        if pos is not None:
            lo, hi = ranges.of["position"]
            if isinstance(pos, list) and len(pos) == 3 and all(_is_number(v) and lo <= v <= hi for v in pos):
                position = (float(pos[0]), float(pos[1]), float(pos[2]))
            else:
                p.add(f"{key}.position",
                      f"expected [x, y, z] numbers within [{lo:g}, {hi:g}]{ranges.unit}, found {_show(pos)}")
        features.append(Feature(fid, fw, ft, position))
    feature_ids = {f.id: f for f in features}
    if not features:
        p.add("features", "the model declares no feature")

    dimensions = _dimensions(p, doc, feature_ids, ranges)
    if resolution is not None and not p.items:
        _check_resolution(p, resolution, limit or 0.1, [*wks, *tools], dimensions, unit)
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
        spindle=str(axis),
        draft=draft,
    )
    if "effects" in doc:
        effects = parse_effects(doc["effects"], model, functools.partial(_report_in, p, "effects"))
        model = replace(model, effects=effects)
    if "safety" in doc:
        model = replace(model, safety=parse_safety(doc["safety"], model.dimension_ids,
                                                   functools.partial(_report_in, p, "safety")))
    p.raise_if_any()
    return model


def _report_in(p: _Problems, section: str, key: str, message: str) -> None:
    p.add(f"{section}.{key}" if key else section, message)


def _dimensions(p: _Problems, doc: Mapping[str, Any], feature_ids: Mapping[str, Feature],
                ranges: _Ranges) -> list[Dimension]:
    dimensions = []
    seen_names: dict[tuple[str, str | None], str] = {}
    for did, raw in _table(p, "dimensions", doc.get("dimensions", {})).items():
        key = f"dimensions.{did}"
        table = _table(p, key, raw)
        _check_keys(p, "dimensions", key, table)
        _control_free(p, key, did, "ID")
        dname = table.get("name", did)
        if not isinstance(dname, str) or not dname.strip():
            p.add(f"{key}.name", f"expected a name, found {_show(dname)}")
            dname = did
        aliases = table.get("aliases", [])
        if not isinstance(aliases, list) or not all(isinstance(a, str) and a.strip() for a in aliases):
            p.add(f"{key}.aliases", f"expected a list of names, found {_show(aliases)}")
            aliases = []
        group = table.get("group")
        if group is not None and not isinstance(group, str):
            p.add(f"{key}.group", f"expected a string, found {_show(group)}")
            group = None
        sampled = table.get("sampled", False)  # not measured every cycle (coverage: pose_problem)
        if not isinstance(sampled, bool):
            p.add(f"{key}.sampled", f"expected true or false, found {_show(sampled)}")
            sampled = False
        if "features" not in table:
            p.add(f"{key}.features", "missing: which features enter this dimension")
        fd = _weights(p, f"{key}.features", table.get("features", {}), feature_ids, "feature")
        values: dict[str, float | None] = {}
        for field_name in ("nominal", "lower", "upper"):
            if field_name not in table:
                what = "nominal value" if field_name == "nominal" else "tolerance limit"
                p.add(f"{key}.{field_name}", f"missing {what}")
                values[field_name] = None
            else:
                within = ranges.of["nominal" if field_name == "nominal" else "tolerance"]
                values[field_name] = _number(p, f"{key}.{field_name}", table[field_name], within=within,
                                             unit=ranges.unit)
        lo, up = values["lower"], values["upper"]
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
        for k in dim.keys:
            if (k, group) in seen_names and seen_names[(k, group)] != did:
                p.add(f"{key}.name", f"name {k!r} is also used by dimension {seen_names[(k, group)]}"
                      + (f" in group {group!r}" if group else ""))
            seen_names[(k, group)] = did
        dimensions.append(dim)
    if not dimensions:
        p.add("dimensions", "the model declares no dimension")
    return dimensions


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
        raise ModelError("TOML nested too deeply (arrays or inline tables inside each other)",
                         location=where) from None
    except ValueError as exc:  # an integer beyond Python's int/str conversion limit
        raise ModelError(f"TOML value out of range: {exc}", location=where) from None
    return model_from_dict(doc, source=str(path), text=text)
