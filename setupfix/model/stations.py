"""Station templates: a multi-part fixture's repeated part declared once.

A fixture holding the same part at several stations repeats the same features and
dimensions with other work coordinate systems.  Instead of copying the tables::

    [stations.P1]
    wks = { B0 = "W1", B180 = "W5" }     # template name -> this station's WKS ID
    [stations.P2]
    wks = { B0 = "W2", B180 = "W6" }

    [template.features.F1]
    wks = { B0 = 1 }                     # a template name, mapped per station
    tools = { T5 = 1 }                   # or a register ID shared by every station
    [template.dimensions.D1]
    name = "D1"                          # "P1 D1", "P2 D1"; or "{station}-D1" where the
    features = { F1 = 1 }                # report writes names another way
    nominal = 25.0
    lower = -0.1
    upper = 0.1

expands, station by station in file order, to ``[features.P1F1]``, ``[dimensions.P1D1]``
(``name = "P1 D1"``, ``aliases = ["D1"]``, ``group = "P1"``) and so on: feature and dimension IDs are the
station ID followed by the template ID; each copy also answers to the name (and aliases)
as written — an ordinary per-part report naming it ``D1`` matches the copy of its station
(the report's ``station`` column or ``--stations P2``: :func:`setupfix.model.match_parts`
tells equal names apart by group); template features referenced by a template
dimension are that station's copies.  ``[stations.*] tools = {…}`` maps template tool
names the same way.  Tables written without templates are untouched, and may be mixed
with templated ones.  The expansion is plain data → plain data; the loader validates
the result and names the template table of every problem.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["expand_stations"]

STATION_KEYS = {"wks", "tools", "description", "comment", "note", "notes"}
TEMPLATE_KEYS = {"features", "dimensions"}

Problem = tuple[str, str]


def _mapping(value: Any, key: str, problems: list[Problem]) -> dict[str, str]:
    if not isinstance(value, Mapping):
        problems.append((key, f"expected a table {{ template name = register ID }}, found {type(value).__name__}"))
        return {}
    out = {}
    for name, target in value.items():
        if not isinstance(target, str) or not target.strip():
            problems.append((f"{key}.{name}", f"expected a register ID (text), found {target!r}"[:120]))
            continue
        out[str(name)] = target.strip()
    return out


def _name(pattern: str, station: str) -> str:
    return pattern.replace("{station}", station) if "{station}" in pattern else f"{station} {pattern}"


def expand_stations(doc: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, str], list[Problem]]:
    """Expand ``[stations]`` and ``[template]`` into plain feature and dimension tables.

    Parameters
    ----------
    doc : mapping
        The parsed TOML document.

    Returns
    -------
    doc : dict
        The document with the templates expanded (``stations`` and ``template`` removed).
    origin : dict
        ``"features.P1F1"`` → ``"template.features.F1"``: where each generated table
        was written, for messages.
    problems : list of (key, message)
        Problems of the template tables themselves.
    """
    out = dict(doc)
    if "stations" not in doc and "template" not in doc:
        return out, {}, []
    problems: list[Problem] = []
    origin: dict[str, str] = {}
    stations_raw = out.pop("stations", {})
    template = out.pop("template", {})
    if not isinstance(stations_raw, Mapping) or not stations_raw:
        problems.append(("stations", "a template needs at least one [stations.<ID>] table"))
        stations_raw = {}
    if not isinstance(template, Mapping):
        problems.append(("template", f"expected a table, found {type(template).__name__}"))
        template = {}
    for key in template:
        if key not in TEMPLATE_KEYS:
            problems.append((f"template.{key}", "unknown key (expected one of: dimensions, features)"))
    t_features = template.get("features", {})
    t_dimensions = template.get("dimensions", {})
    for name, table in (("features", t_features), ("dimensions", t_dimensions)):
        if not isinstance(table, Mapping) or not all(isinstance(v, Mapping) for v in table.values()):
            problems.append((f"template.{name}", f"expected tables [template.{name}.<ID>]"))
    if problems:
        return out, origin, problems

    stations: dict[str, dict[str, dict[str, str]]] = {}
    for sid, raw in stations_raw.items():
        key = f"stations.{sid}"
        if not isinstance(raw, Mapping):
            problems.append((key, f"expected a table, found {type(raw).__name__}"))
            continue
        for k in raw:
            if k not in STATION_KEYS:
                problems.append((f"{key}.{k}", "unknown key (expected one of: tools, wks)"))
        stations[sid] = {kind: _mapping(raw.get(kind, {}), f"{key}.{kind}", problems) for kind in ("wks", "tools")}

    declared = {
        kind: set(doc.get(kind, {})) if isinstance(doc.get(kind), Mapping) else set() for kind in ("wks", "tools")
    }
    # Every template name a feature uses must be a declared register or mapped by every station.
    for fid, ftable in t_features.items():
        for kind in ("wks", "tools"):
            refs = ftable.get(kind, {})
            if not isinstance(refs, Mapping):
                continue
            for ref in refs:
                if ref in declared[kind]:
                    continue
                missing = [sid for sid, maps in stations.items() if ref not in maps[kind]]
                if missing:
                    problems.append(
                        (
                            f"template.features.{fid}.{kind}.{ref}",
                            f"{ref!r} is neither a declared {'WKS' if kind == 'wks' else 'tool'} nor "
                            f"mapped by station(s) {', '.join(missing)} ([stations.<ID>] {kind} = {{…}})",
                        )
                    )
    for sid, maps in stations.items():
        used = {
            ref for f in t_features.values() for ref in (f.get("wks", {}) if isinstance(f.get("wks"), Mapping) else {})
        }
        used |= {
            ref
            for f in t_features.values()
            for ref in (f.get("tools", {}) if isinstance(f.get("tools"), Mapping) else {})
        }
        for kind, mapping in maps.items():
            for ref in mapping:
                if ref not in used:
                    problems.append(
                        (f"stations.{sid}.{kind}.{ref}", f"template name {ref!r} is used by no template feature")
                    )

    features = dict(out.get("features", {})) if isinstance(out.get("features"), Mapping) else {}
    dimensions = dict(out.get("dimensions", {})) if isinstance(out.get("dimensions"), Mapping) else {}
    for sid, maps in stations.items():
        for fid, ftable in t_features.items():
            new_id = f"{sid}{fid}"
            table = dict(ftable)
            for kind in ("wks", "tools"):
                refs = ftable.get(kind)
                if isinstance(refs, Mapping):
                    table[kind] = {maps[kind].get(ref, ref): w for ref, w in refs.items()}
            _place(features, "features", new_id, table, f"template.features.{fid}", origin, problems)
        for did, dtable in t_dimensions.items():
            new_id = f"{sid}{did}"
            table = dict(dtable)
            name = dtable.get("name", did)
            plain: list[str] = []  # the names as written, matched with the report's station (per-part reports)
            if isinstance(name, str):
                table["name"] = _name(name, sid)
                plain += [name] if "{station}" not in name else []
            aliases = dtable.get("aliases")
            if isinstance(aliases, list):
                table["aliases"] = [_name(a, sid) if isinstance(a, str) else a for a in aliases]
                plain += [a for a in aliases if isinstance(a, str) and "{station}" not in a]
            if plain:
                known = {table.get("name"), *table.get("aliases", [])}
                table["aliases"] = [*table.get("aliases", []), *(a for a in dict.fromkeys(plain) if a not in known)]
            components = dtable.get("components")  # a zone's: "{station}" stands for the station, as in a name
            if isinstance(components, list):
                table["components"] = [c.replace("{station}", sid) if isinstance(c, str) else c for c in components]
            refs = dtable.get("features")
            if isinstance(refs, Mapping):
                table["features"] = {(f"{sid}{ref}" if ref in t_features else ref): w for ref, w in refs.items()}
            if "group" in dtable:
                problems.append(
                    (
                        f"template.dimensions.{did}.group",
                        "the group of a templated dimension is its station; remove the key",
                    )
                )
            table["group"] = sid
            _place(dimensions, "dimensions", new_id, table, f"template.dimensions.{did}", origin, problems)
    out["features"] = features
    out["dimensions"] = dimensions
    return out, origin, problems


def _place(
    section: dict[str, Any],
    name: str,
    new_id: str,
    table: dict[str, Any],
    where: str,
    origin: dict[str, str],
    problems: list[Problem],
) -> None:
    if new_id in section:
        problems.append((where, f"expands to [{name}.{new_id}], which is also declared in the file"))
        return
    section[new_id] = table
    origin[f"{name}.{new_id}"] = where
