"""Load and validate a process model file (``../shared/spec/process-model.md``).

Every problem is collected with its key path before anything is raised, so the
engineer fixes the file in one pass: :class:`~setupfix.errors.ModelError` carries
the list in ``problems`` and its text has one line per problem.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from setupfix.errors import ModelError, SourceLocation
from setupfix.model.process import (
    Dimension,
    Feature,
    MachinePoint,
    ProcessModel,
    Register,
    RegisterKind,
)
from setupfix.model.safety import DIMENSION_KEYS, REGISTER_KEYS, SAFETY_KEYS, safety_from_doc
from setupfix.units import LENGTH_UNITS

__all__ = ["load_model", "model_from_dict"]

_FREE_TEXT = {"description", "comment", "note", "notes"}
_KEYS = {
    "process": {"name", "axis", "unit", "resolution", "limit"} | _FREE_TEXT,
    "machine": {"wks"} | _FREE_TEXT,
    "wks": {"register", "limit", "fixed"} | _FREE_TEXT,
    "tools": {"register", "limit", "fixed"} | _FREE_TEXT,
    "features": {"wks", "tools", "position"} | _FREE_TEXT,
    "dimensions": {"name", "aliases", "features", "nominal", "lower", "upper", "group"} | _FREE_TEXT,
}
# Safety rules and register preferences (setupfix.model.safety) extend the tables.
_KEYS["wks"] |= REGISTER_KEYS
_KEYS["tools"] |= REGISTER_KEYS
_KEYS["dimensions"] |= DIMENSION_KEYS
_KEYS["safety"] = set(SAFETY_KEYS) | _FREE_TEXT


class _Problems:
    """Collects problems with their key paths."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.items: list[ModelError] = []

    def add(self, key: str, message: str) -> None:
        self.items.append(ModelError(message, location=SourceLocation(self.path, key=key)))

    def raise_if_any(self) -> None:
        if self.items:
            text = "\n".join(str(p) for p in self.items)
            err = ModelError(text)
            err.problems = self.items  # type: ignore[attr-defined]
            raise err


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _number(p: _Problems, key: str, value: Any, *, positive: bool = False) -> float | None:
    if not _is_number(value):
        p.add(key, f"expected a number, found {value!r}")
        return None
    if positive and value <= 0:
        p.add(key, f"must be > 0, found {value!r}")
        return None
    return float(value)


def _table(p: _Problems, key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        p.add(key, f"expected a table, found {type(value).__name__}")
        return {}
    return dict(value)


def _check_keys(p: _Problems, section: str, key: str, table: Mapping[str, Any]) -> None:
    for name in table:
        if name not in _KEYS[section]:
            allowed = ", ".join(sorted(_KEYS[section] - _FREE_TEXT))
            p.add(f"{key}.{name}", f"unknown key (expected one of: {allowed})")


def _weights(p: _Problems, key: str, value: Any, known: Mapping[str, Any], what: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for ref, weight in _table(p, key, value).items():
        if ref not in known:
            p.add(f"{key}.{ref}", f"unknown {what} {ref!r}")
            continue
        w = _number(p, f"{key}.{ref}", weight)
        if w is not None and w != 0.0:
            out[ref] = w
    return out


def _registers(p: _Problems, doc: dict[str, Any], section: str, kind: RegisterKind, limit: float) -> list[Register]:
    regs = []
    for rid, raw in _table(p, section, doc.get(section, {})).items():
        key = f"{section}.{rid}"
        table = _table(p, key, raw)
        _check_keys(p, section, key, table)
        name = table.get("register", rid)
        if not isinstance(name, str) or not name.strip():
            p.add(f"{key}.register", f"expected a register name, found {name!r}")
            name = rid
        lim = _number(p, f"{key}.limit", table["limit"], positive=True) if "limit" in table else limit
        fixed = table.get("fixed", False)
        if not isinstance(fixed, bool):
            p.add(f"{key}.fixed", f"expected true or false, found {fixed!r}")
            fixed = False
        regs.append(Register(rid, kind, name.strip(), lim if lim is not None else limit, fixed))
    return regs


def model_from_dict(doc: Mapping[str, Any], source: str = "<model>") -> ProcessModel:
    """Validate a parsed model document and build the :class:`ProcessModel`.

    Raises
    ------
    ModelError
        With one line per problem, each naming ``source`` and the key path.
    """
    p = _Problems(source)
    doc = dict(doc)
    for top in doc:
        if top not in _KEYS:
            p.add(top, f"unknown table (expected one of: {', '.join(_KEYS)})")
    if "process" not in doc:
        p.add("process", "missing required table [process]")
    proc = _table(p, "process", doc.get("process", {}))
    _check_keys(p, "process", "process", proc)
    name = proc.get("name")
    if "process" in doc and (not isinstance(name, str) or not name.strip()):
        p.add("process.name", "missing required process name")
    axis = proc.get("axis", "Z")
    if axis not in ("X", "Y", "Z"):
        p.add("process.axis", f'expected "X", "Y" or "Z", found {axis!r}')
    unit = proc.get("unit", "mm")
    if not isinstance(unit, str) or LENGTH_UNITS.get(unit.strip().lower()) is None:
        p.add("process.unit", f'unknown unit {unit!r} (expected "mm" or "inch")')
        unit = "mm"
    unit = LENGTH_UNITS[unit.strip().lower()]
    resolution = _number(p, "process.resolution", proc.get("resolution", 0.001), positive=True) or 0.001
    limit = _number(p, "process.limit", proc.get("limit", 0.1), positive=True) or 0.1

    wks = _registers(p, doc, "wks", "wks", limit)
    tools = _registers(p, doc, "tools", "tool", limit)
    wks_ids = {r.id: r for r in wks}
    tool_ids = {r.id: r for r in tools}
    for rid in wks_ids.keys() & tool_ids.keys():
        p.add(f"tools.{rid}", f"ID {rid!r} is declared both as a WKS and as a tool")
    seen_reg: dict[str, str] = {}
    for reg in (*wks, *tools):
        section = "wks" if reg.kind == "wks" else "tools"
        folded = reg.register.casefold()
        if folded in seen_reg:
            p.add(f"{section}.{reg.id}.register", f"register {reg.register!r} is also used by {seen_reg[folded]}")
        seen_reg[folded] = reg.id
    if not wks and not tools:
        p.add("wks", "the model declares no WKS and no tool: nothing to correct")

    machines = []
    for mid, raw in _table(p, "machine", doc.get("machine", {})).items():
        table = _table(p, f"machine.{mid}", raw)
        _check_keys(p, "machine", f"machine.{mid}", table)
        machines.append(MachinePoint(mid, _weights(p, f"machine.{mid}.wks", table.get("wks", {}), wks_ids, "WKS")))

    features = []
    for fid, raw in _table(p, "features", doc.get("features", {})).items():
        key = f"features.{fid}"
        table = _table(p, key, raw)
        _check_keys(p, "features", key, table)
        fw = _weights(p, f"{key}.wks", table.get("wks", {}), wks_ids, "WKS")
        ft = _weights(p, f"{key}.tools", table.get("tools", {}), tool_ids, "tool")
        pos = table.get("position")
        position = None
        if pos is not None:
            if isinstance(pos, list) and len(pos) == 3 and all(_is_number(v) for v in pos):
                position = (float(pos[0]), float(pos[1]), float(pos[2]))
            else:
                p.add(f"{key}.position", f"expected [x, y, z] numbers, found {pos!r}")
        features.append(Feature(fid, fw, ft, position))
    feature_ids = {f.id: f for f in features}
    if not features:
        p.add("features", "the model declares no feature")

    dimensions = []
    seen_names: dict[tuple[str, str | None], str] = {}
    for did, raw in _table(p, "dimensions", doc.get("dimensions", {})).items():
        key = f"dimensions.{did}"
        table = _table(p, key, raw)
        _check_keys(p, "dimensions", key, table)
        dname = table.get("name", did)
        if not isinstance(dname, str) or not dname.strip():
            p.add(f"{key}.name", f"expected a name, found {dname!r}")
            dname = did
        aliases = table.get("aliases", [])
        if not isinstance(aliases, list) or not all(isinstance(a, str) and a.strip() for a in aliases):
            p.add(f"{key}.aliases", f"expected a list of names, found {aliases!r}")
            aliases = []
        group = table.get("group")
        if group is not None and not isinstance(group, str):
            p.add(f"{key}.group", f"expected a string, found {group!r}")
            group = None
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
                values[field_name] = _number(p, f"{key}.{field_name}", table[field_name])
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
        )
        for k in dim.keys:
            if (k, group) in seen_names and seen_names[(k, group)] != did:
                p.add(f"{key}.name", f"name {k!r} is also used by dimension {seen_names[(k, group)]}"
                      + (f" in group {group!r}" if group else ""))
            seen_names[(k, group)] = did
        dimensions.append(dim)
    if not dimensions:
        p.add("dimensions", "the model declares no dimension")
    safety = safety_from_doc(doc, p.add)
    p.raise_if_any()
    return ProcessModel(
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
        safety=safety,
    )


def load_model(path: str | Path) -> ProcessModel:
    """Read and validate a process model TOML file.

    Raises
    ------
    ModelError
        If the file is missing, not TOML, or breaks the contract; the message names
        the file and the line (syntax) or key path (content) of every problem.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ModelError(f"cannot read model: {exc.strerror}", location=SourceLocation(str(path))) from None
    try:
        doc = tomllib.loads(raw.decode("utf-8-sig"))
    except UnicodeDecodeError as exc:
        raise ModelError(f"not UTF-8 text (byte {exc.start})", location=SourceLocation(str(path))) from None
    except tomllib.TOMLDecodeError as exc:
        # Python 3.11 puts the position only in the text: "… (at line 3, column 7)".
        found = re.search(r"\(at line (\d+), column \d+\)|\(at end of document\)", str(exc))
        msg = str(exc).replace(found.group(0), "").strip() if found else str(exc)
        line = int(found.group(1)) if found and found.group(1) else raw.count(b"\n") + 1 if found else None
        raise ModelError(f"TOML syntax: {msg}", location=SourceLocation(str(path), line=line)) from None
    return model_from_dict(doc, source=str(path))
