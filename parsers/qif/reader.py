"""QIF 3.x and 2.x measurement results → the canonical measurement table.

A measured value reaches its name, nominal and tolerance through a chain of ids:
measurement (``…CharacteristicMeasurement`` in QIF 3, ``…CharacteristicActual`` in
QIF 2) → ``CharacteristicItemId`` → item (name) → ``CharacteristicNominalId`` →
nominal (``TargetValue``) → ``CharacteristicDefinitionId`` → definition (tolerance).
Each ``MeasurementResults`` is one part, named by the serial number of its actual
component.  Rows carry ``file#id`` of their measurement element as provenance.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from lxml import etree

from parsers.canonical import finish_table
from parsers.notes import note
from parsers.qif.external import build_index, resolve_external
from parsers.qif.features import NO_FEATURES, FeatureGeometry, ResultsFeatures, datum_labels, measurement_features
from parsers.qif.flatten import Record, measurement_table, record, results_elements
from parsers.qif.items import Doc, Item, child_text, item_info, local, number, owner_mm, raw_float
from parsers.qif.units import choose_file_unit, file_unit_factor, unit_factor
from parsers.qif.xmltree import parse_xml
from parsers.source import Source, read_bytes
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.model.measurements import (
    ACTUAL_POSITION_COLUMNS,
    BETWEEN_COLUMN,
    CALLOUT_COLUMN,
    DATUMS_COLUMN,
    FEATURE_DIRECTION_COLUMNS,
    FEATURE_ID_COLUMN,
    UNCERTAINTY_COLUMN,
)

__all__ = ["read_qif", "sniff_qif", "NON_LENGTH_KINDS"]

#: Characteristic kinds whose value is not a length (angles, attributes, …): skipped.
NON_LENGTH_KINDS = frozenset(
    {
        "Angle",
        "AngleBetween",
        "AngleFrom",
        "AngularCoordinate",
        "UserDefinedAngular",
        "UserDefinedAttribute",
        "UserDefinedArea",
        "UserDefinedForce",
        "UserDefinedMass",
        "UserDefinedPressure",
        "UserDefinedSpeed",
        "UserDefinedTemperature",
        "UserDefinedTime",
        "Threaded",
        "SurfaceTexture",
        "Weld",
        "WeldBevel",
        "WeldFillet",
        "Note",
    }
)

_SUFFIXES = ("CharacteristicMeasurement", "CharacteristicActual")
#: Text fields of :class:`~parsers.qif.items.Item` (the others are numbers).
_TEXT_FIELDS = ("label", "axis", "feature", "size", "side")


def sniff_qif(text: str) -> bool:
    """True when the first bytes of a file are a QIF document. Never raises."""
    return "<QIFDocument" in text[:4096]


#: ``AttributeStr`` names of an actual component that say which load (fixture cycle)
#: and which fixture station it was machined in; QIF has no element for either.
_CYCLE_ATTRIBUTES = ("cycle", "load")
_STATION_ATTRIBUTES = ("station", "nest", "fixture station")


def _report_date(results: etree._Element, root: etree._Element, ns: str) -> str:
    """``InspectionTraceability/ReportPreparationDate`` of the part's results, else of the
    document's: when it was inspected, the nearest a QIF file comes to when it was machined."""
    path = f"{{{ns}}}InspectionTraceability/{{{ns}}}ReportPreparationDate"
    own: str | None = results.findtext(path)
    if own and own.strip():
        return own.strip()
    container = results.getparent()
    while container is not None and container.getparent() is not root:
        container = container.getparent()
    return (container.findtext(path) or "").strip() if container is not None else ""


def _part_name(results: etree._Element, doc: Doc) -> tuple[str, str]:
    """(part, station) of one ``MeasurementResults``: cycle attribute or serial number,
    station attribute; ``results <id>`` when the component has neither."""
    ns = doc.ns
    serial = station = cycle = ""
    for ref in results.iterfind(f"{{{ns}}}ActualComponentIds/{{{ns}}}Id"):
        comp = doc.index.local.get((ref.text or "").strip())
        if comp is None:
            continue
        for attr in comp.iterfind(f"{{{ns}}}Attributes/{{{ns}}}AttributeStr"):
            key = (attr.get("name") or "").strip().lower()
            if key in _CYCLE_ATTRIBUTES and not cycle:
                cycle = (attr.get("value") or "").strip()
            elif key in _STATION_ATTRIBUTES and not station:
                station = (attr.get("value") or "").strip()
        serial = serial or child_text(comp, ns, "SerialNumber")
    return cycle or serial or f"results {results.get('id', '?')}", station


def read_qif(path: str | Path | Source, *, unit: str | None = None) -> pd.DataFrame:
    """Read the measurement results of a QIF 3.x or 2.x document.

    Parameters
    ----------
    path : str or Path
        The QIF file.  Results that reference characteristics in an external plan
        are resolved against a plan beside the file (by URI or QPId).
    unit : {"mm", "inch"}, optional
        Unit of a file without ``FileUnits`` (see :mod:`parsers.qif.units`).

    Raises
    ------
    ParseError
        On unsafe or malformed XML, a document without measurement results, a broken
        id reference or an unresolvable external plan; names file and element.
    """
    name = str(path)
    root = parse_xml(read_bytes(path), name)
    if local(root.tag) != "QIFDocument":
        raise ParseError(
            f"root element is <{local(root.tag)}>, not <QIFDocument>",
            location=SourceLocation(name, line=root.sourceline),
        )
    ns = etree.QName(root).namespace or ""
    doc = Doc(name, root, ns, build_index(root))
    results = results_elements(root, ns)
    if not results:
        raise ParseError(
            "no measurement results: this QIF document is a plan or product definition",
            location=SourceLocation(name),
            hint="give the QIF results file",
        )
    declared = file_unit_factor(root, ns, name)
    table = measurement_table(root, ns)
    if table.empty:
        raise ParseError(
            "measurement results hold no characteristic values (only an inspection status)",
            location=SourceLocation(name, line=results[0].sourceline, element="MeasurementResults"),
        )
    parts = [_part_name(res, doc) for res in results]
    stamps = np.asarray([_report_date(res, root, ns) for res in results], dtype=object)
    missing = ~table["has_item"] | (table["item"] == "")
    if missing.any():
        _item_key(record(table, int(missing.to_numpy().argmax())), results, doc, {})
    # Everything per characteristic item is resolved once; per measurement only columns are mapped.
    keys = table["item"].where(table["external"] == "", "\0" + table["item"] + "\0" + table["external"])
    firsts = ~keys.duplicated()
    plans: dict[str, Doc] = {}
    key_list: list[str] = keys.tolist()
    chains: dict[str, tuple[etree._Element, etree._Element, etree._Element, Doc]] = {}
    for index in np.flatnonzero(firsts.to_numpy()):
        rec = record(table, int(index))
        chains[key_list[index]] = _chain(rec, _item_key(rec, results, doc, plans), results, doc, plans)
    raw_nominals = [raw_float(child_text(nom, owner.ns, "TargetValue")) for _, nom, _, owner in chains.values()]
    mm = choose_file_unit(declared, raw_nominals, name, unit)
    kinds = {tag: _kind(tag) for tag in table["tag"].unique()}
    kind = table["tag"].map(kinds)
    kind_list: list[str] = kind.tolist()
    notes: set[str] = set()
    infos: dict[str, Item | str] = {}
    for index in np.flatnonzero(firsts.to_numpy()):
        key = key_list[index]
        k = kind_list[index]
        infos[key] = f"{k} (not a length)" if k in NON_LENGTH_KINDS else item_info(k, *chains[key], doc, mm, notes)
    reason = keys.map({k: (v if isinstance(v, str) else "") for k, v in infos.items()}).astype(object)
    reason = reason.where(~kind.isin(NON_LENGTH_KINDS), kind + " (not a length)")
    actual = _actuals(table, results, name, ns, mm)
    reason = reason.where((reason != "") | actual.notna(), "without a measured value")
    skipped: dict[str, list[str]] = {}
    for why, ids in table["id"].groupby(reason, sort=True):
        if why:
            skipped[str(why)] = [i or "?" for i in ids]
    keep = (reason == "").to_numpy()
    if skipped:
        what = "; ".join(
            f"{len(ids)} {k} (#{', #'.join(ids[:3])}{', …' if len(ids) > 3 else ''})" for k, ids in skipped.items()
        )
        note(f"skipped {what}", SourceLocation(name), "skipped")
    for text in sorted(notes):
        note(text, SourceLocation(name), "parse")
    if not keep.any():
        raise ParseError("no length characteristics among the measurement results", location=SourceLocation(name))
    kept = table[keep]
    known = [k for k, v in infos.items() if isinstance(v, Item)]
    code = keys[keep].map({k: i for i, k in enumerate(known)}).to_numpy(dtype=int)
    part_of = np.asarray([p[0] for p in parts], dtype=object)[kept["results"].to_numpy()]
    station_of = np.asarray([p[1] for p in parts], dtype=object)[kept["results"].to_numpy()]
    columns: dict[str, object] = {
        field: np.asarray([getattr(infos[k], field) for k in known], dtype=object if field in _TEXT_FIELDS else None)[
            code
        ]
        for field in Item.__dataclass_fields__
    }
    labels = pd.Series(columns.pop("label"), dtype=object)
    # One item measured several times in a part (point profiles): keep each, apart.
    count = labels.groupby([part_of, station_of, labels.to_numpy()], sort=False).cumcount().to_numpy() + 1
    labels = labels.where(count == 1, labels + " (" + count.astype(str) + ")")
    element_ids = kept["id"].to_numpy(dtype=object)
    source = np.where(element_ids != "", name + "#" + element_ids.astype(str), "")
    results_of = kept["results"].to_numpy()
    for i in np.flatnonzero(element_ids == ""):
        row = int(i)
        source[i] = f"{name}:{_find(results[int(results_of[row])], record(kept, kept.index[row]), ns).sourceline}"
    columns.update(_feature_columns(kept, keys[keep].tolist(), chains, results, doc, mm, x_y_z=columns))
    columns[UNCERTAINTY_COLUMN] = _uncertainty(kept, results, name, ns, mm)
    columns[CALLOUT_COLUMN] = kind[keep].map(lambda k: CALLOUT_OF_KIND.get(k, "")).to_numpy(dtype=object)
    columns.update(
        {
            "characteristic": labels.to_numpy(),
            "actual": actual[keep].to_numpy(),
            "part": part_of,
            "station": station_of,
            "status": kept["status"].to_numpy(),
            "source": source,
            "timestamp": stamps[kept["results"].to_numpy()],
        }
    )
    return finish_table(columns, name)


def _actuals(table: pd.DataFrame, results: list[etree._Element], name: str, ns: str, mm: float) -> pd.Series:
    """Measured values in mm (NaN where absent); a value that is not a number is an error."""
    first = table["value"].str.split(n=1).str[0].fillna("")
    actual = pd.to_numeric(first.where(first != "", None), errors="coerce").astype(float) * mm
    odd = (table["unit"] != "") | ((first != "") & ~np.isfinite(actual))
    for index in np.flatnonzero(odd.to_numpy()):
        rec = record(table, int(table.index[int(index)]))
        element = _find(results[rec.results], rec, ns).find(f"{{{ns}}}Value")
        actual.iat[int(index)] = number(element, name, mm)
    return actual


def _feature_columns(
    kept: pd.DataFrame,
    keys: list[str],
    chains: dict[str, tuple[etree._Element, etree._Element, etree._Element, Doc]],
    results: list[etree._Element],
    doc: Doc,
    mm: float,
    *,
    x_y_z: dict[str, object],
) -> dict[str, object]:
    """The feature columns of each kept measurement (:mod:`parsers.qif.features`).

    The nominal location ``x, y, z`` of a measurement's own feature replaces its item's
    (given in ``x_y_z``) where the feature states one: an item measured on several
    features gets each feature's position.
    """
    n = len(kept)
    nominal = np.column_stack([np.asarray(x_y_z[c], dtype=float) for c in ("x", "y", "z")]) if n else np.empty((0, 3))
    actual = np.full((n, 3), np.nan)
    direction = np.full((n, 3), np.nan)
    feature_id = np.full(n, "", dtype=object)
    between = np.full(n, "", dtype=object)
    datums = np.full(n, "", dtype=object)
    per_results: dict[int, ResultsFeatures] = {}
    frames: dict[str, str] = {}
    owned: dict[str, bool] = {}  # item key → whether the item names features
    scales: dict[int, float] = {}
    swapped = broken = 0
    for row, (key, res, ids) in enumerate(zip(keys, kept["results"].tolist(), kept["features"].tolist(), strict=True)):
        item, nom, definition, owner = chains[key]
        if key not in frames:
            frames[key] = datum_labels(definition, nom, owner)
        datums[row] = frames[key]
        if not ids.strip():
            has = owned.get(key)
            if has is None:
                has = owned[key] = item.find(f"{{{owner.ns}}}FeatureItemIds") is not None
            if not has:
                continue  # a characteristic of no stated feature: its item's location stands
        found = per_results.get(res)
        if found is None:
            found = per_results[res] = ResultsFeatures(results[res], doc.ns)
        scale = scales.get(id(owner))
        if scale is None:
            scale = scales[id(owner)] = mm if owner is doc else owner_mm(owner, mm)
        geometry: FeatureGeometry = measurement_features(ids.split(), item, found, doc, owner, mm, scale)
        if geometry is NO_FEATURES:
            continue
        swapped += geometry.swapped
        broken += geometry.broken
        if geometry.swapped or geometry.broken or not math.isnan(geometry.nominal[0]):
            nominal[row] = geometry.nominal
        actual[row] = geometry.actual
        direction[row] = geometry.direction
        feature_id[row] = geometry.feature_id
        between[row] = geometry.between
    if swapped:
        note(
            f"{swapped} measurement(s) of features whose Normal is not a unit vector (Location and Normal "
            "swapped?): their positions and directions are left out",
            SourceLocation(doc.path),
            "parse",
        )
    if broken:
        note(
            f"{broken} measurement(s) name features that are not in the file (FeatureActualIds or their "
            "FeatureItemId point nowhere): their feature columns and positions are left out",
            SourceLocation(doc.path),
            "parse",
        )
    out: dict[str, object] = {c: nominal[:, k] for k, c in enumerate(("x", "y", "z"))}
    out.update({c: actual[:, k] for k, c in enumerate(ACTUAL_POSITION_COLUMNS)})
    out.update({c: direction[:, k] for k, c in enumerate(FEATURE_DIRECTION_COLUMNS)})
    out.update({FEATURE_ID_COLUMN: feature_id, BETWEEN_COLUMN: between, DATUMS_COLUMN: datums})
    return out


#: The ``callout`` word of a characteristic kind (``DistanceFrom`` is a location from a datum: none).
CALLOUT_OF_KIND = {"DistanceBetween": "distance", "AngleBetween": "angle", "Position": "position"}

#: Coverage factor of the expanded uncertainty the ``uncertainty`` column holds (ISO 14253-1, GUM).
COVERAGE_FACTOR = 2.0


def _uncertainty(kept: pd.DataFrame, results: list[etree._Element], name: str, ns: str, mm: float) -> np.ndarray:
    """U = k·u_c (k = 2) of each kept measurement in mm: ``u_c`` its ``Value``'s ``combinedUncertainty``
    (QIF: the combined standard uncertainty) in the value's unit; NaN where absent.

    Raises
    ------
    ParseError
        For a ``combinedUncertainty`` that is not a non-negative number, at its element.
    """
    text = kept["uncertainty"].to_numpy(dtype=object)
    out = np.full(len(kept), np.nan)
    for i in np.flatnonzero(text != ""):
        row = int(i)
        unit = str(kept["unit"].iat[row])
        factor = (unit_factor(unit) if unit else mm) or math.nan
        value = raw_float(str(text[row]))
        if not value >= 0.0:  # NaN (not a number) too
            rec = record(kept, kept.index[row])
            element = _find(results[rec.results], rec, ns)
            raise ParseError(
                f"combinedUncertainty {text[row]!r} is not a non-negative number",
                location=SourceLocation(name, line=element.sourceline, element=f"{rec.tag} id={rec.id}"),
            )
        out[row] = COVERAGE_FACTOR * value * factor
    return out


def _kind(tag: str) -> str:
    kind = local(tag)
    for suffix in _SUFFIXES:
        kind = kind.removesuffix(suffix)
    return kind


def _find(res: etree._Element, rec: Record, ns: str) -> etree._Element:
    """The element of a record, for messages (found again by id; the results element if none)."""
    if rec.id:
        found = res.xpath(".//*[@id=$i]", i=rec.id)
        if found:
            return found[0]
    return res


def _where(rec: Record, results: list[etree._Element], doc: Doc) -> SourceLocation:
    el = _find(results[rec.results], rec, doc.ns)
    return SourceLocation(doc.path, line=el.sourceline, element=f"{rec.tag} id={rec.id}")


def _item_key(rec: Record, results: list[etree._Element], doc: Doc, plans: dict[str, Doc]) -> tuple[str, str]:
    """(path of the document holding the item, item id) of one measurement."""
    if not rec.item:
        raise ParseError("measurement without CharacteristicItemId", location=_where(rec, results, doc))
    if not rec.external:
        return doc.path, rec.item
    if rec.item not in plans:
        plan_path, plan_root = resolve_external(doc.root, doc.ns, doc.path, rec.item, _where(rec, results, doc))
        plan_ns = etree.QName(plan_root).namespace or ""
        plans[rec.item] = Doc(plan_path, plan_root, plan_ns, build_index(plan_root))
    return f"\0{rec.item}", rec.external


def _chain(
    rec: Record, key: tuple[str, str], results: list[etree._Element], doc: Doc, plans: dict[str, Doc]
) -> tuple[etree._Element, etree._Element, etree._Element, Doc]:
    """(item, nominal, definition, document holding them) of one measurement."""
    owner = plans[key[0][1:]] if key[0].startswith("\0") else doc
    item_id = key[1]
    item = owner.index.local.get(item_id)
    if item is None:
        raise ParseError(f"CharacteristicItemId {item_id} refers to no element", location=_where(rec, results, doc))
    nominal = owner.index.local.get(child_text(item, owner.ns, "CharacteristicNominalId"))
    if nominal is None:
        raise ParseError(
            f"characteristic item {item_id} has no valid CharacteristicNominalId", location=_where(rec, results, doc)
        )
    definition = owner.index.local.get(child_text(nominal, owner.ns, "CharacteristicDefinitionId"))
    if definition is None:
        raise ParseError(
            f"characteristic nominal {nominal.get('id')} has no valid CharacteristicDefinitionId",
            location=_where(rec, results, doc),
        )
    return item, nominal, definition, owner
