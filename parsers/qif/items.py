"""QIF characteristic items: name, nominal, limits and location, resolved once per item.

Shared by every measurement of the item (all parts of a multi-part file), so the
per-item work here — following ids, converting units, turning ``DefinedAsLimit``
limits into signed deviations — is independent of the number of parts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lxml import etree

from parsers.axes import AXIS_COSINE, axis_word, cross, vector_axis
from parsers.geometry import axis_vector, unit_vector
from parsers.numbers import parse_number, try_number
from parsers.qif.external import IdIndex
from parsers.qif.units import file_unit_factor, unit_factor
from setupfix.core.errors import ParseError, SourceLocation

__all__ = [
    "PROFILE_KINDS",
    "Doc",
    "Item",
    "item_info",
    "item_axis",
    "item_geometry",
    "local",
    "number",
    "child_text",
    "raw_float",
    "owner_mm",
]


#: Profile kinds: the value is a signed deviation from the true profile, the zone is
#: centred on it unless ``OuterDisposition`` shifts it (ASME unequal disposition).
PROFILE_KINDS = frozenset({"PointProfile", "LineProfile", "SurfaceProfile", "SurfaceProfileNonUniform"})


@dataclass(frozen=True)
class Doc:
    """A parsed QIF document: its path, root element, namespace and id index."""

    path: str
    root: etree._Element
    ns: str
    index: IdIndex


def local(tag: object) -> str:
    """Local name of an lxml tag (``{ns}Name`` → ``Name``); "" for comments."""
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def number(el: etree._Element | None, path: str, mm: float) -> float:
    """Value of a length element in mm (its own ``linearUnit`` first); NaN when absent."""
    if el is None or el.text is None:
        return math.nan
    words = el.text.split()
    if not words:
        return math.nan
    value = parse_number(words[0], location=SourceLocation(path, line=el.sourceline, element=local(el.tag)))
    own = el.get("linearUnit")
    if own:
        factor = unit_factor(own)
        if factor is None:
            raise ParseError(
                f"unknown linearUnit {own!r}", location=SourceLocation(path, line=el.sourceline, element=local(el.tag))
            )
        return value * factor
    return value * mm


def _child(el: etree._Element | None, ns: str, name: str) -> etree._Element | None:
    return None if el is None else el.find(f"{{{ns}}}{name}")


def child_text(el: etree._Element | None, ns: str, name: str) -> str:
    found = _child(el, ns, name)
    return (found.text or "").strip() if found is not None else ""


def _features(item: etree._Element, doc: Doc) -> list[etree._Element | None]:
    """The nominal of each feature of the item (item → feature item → feature nominal); None where broken."""
    ns, ids = doc.ns, doc.index.local
    out: list[etree._Element | None] = []
    for ref in item.iterfind(f"{{{ns}}}FeatureItemIds/{{{ns}}}Id"):
        feature = ids.get((ref.text or "").strip())
        out.append(ids.get(child_text(feature, ns, "FeatureNominalId")) if feature is not None else None)
    return out


def _location(item: etree._Element, doc: Doc, mm: float) -> tuple[float, float, float]:
    """Nominal location of the item's first feature (item → feature item → nominal)."""
    features = _features(item, doc)
    nominal = features[0] if features else None
    loc = _child(nominal, doc.ns, "Location")
    if loc is None or not loc.text:
        return (math.nan, math.nan, math.nan)
    xyz = [try_number(v, scale=mm) for v in loc.text.split()[:3]]
    if len(xyz) != 3 or None in xyz:
        return (math.nan, math.nan, math.nan)
    return (float(xyz[0]), float(xyz[1]), float(xyz[2]))  # type: ignore[arg-type]  # no None: tested above


def _vector(el: etree._Element | None) -> tuple[float, float, float] | None:
    """Three numbers of a vector element (``Normal``, ``AnalysisVector``, …); None when absent or not numbers."""
    words = (el.text or "").split() if el is not None else []
    values = [try_number(w) for w in words]
    if len(values) != 3 or any(v is None for v in values):
        return None
    return (float(values[0]), float(values[1]), float(values[2]))  # type: ignore[arg-type]  # no None: tested above


def _unit(vector: tuple[float, float, float] | None) -> tuple[float, float, float] | None:
    norm = math.sqrt(sum(v * v for v in vector)) if vector is not None else 0.0
    if vector is None or not math.isfinite(norm) or norm == 0.0:
        return None
    return (vector[0] / norm, vector[1] / norm, vector[2] / norm)


#: Kinds whose value is a distance: along the ``AnalysisVector``, else perpendicular to a plane feature.
_DISTANCES = frozenset({"DistanceBetween", "DistanceFrom"})
#: Features whose ``Normal`` is the surface normal a point-profile deviation is measured along.
_SURFACES = frozenset({"PointFeatureNominal", "PlaneFeatureNominal"})


def item_axis(kind: str, item: etree._Element, nom: etree._Element, owner: Doc) -> str:
    """The machine axis along which the report measures a characteristic, else ``""`` (:mod:`parsers.axes`).

    In order: the nominal's ``Direction`` word (``LinearCoordinate``: ``XAXIS`` …); its
    ``AnalysisVector``; for a point profile, the surface normal of its point (or plane)
    feature (not of an edge point: its deviation may be along either of its two normals);
    for a distance, the common normal of its plane features (a distance to a plane is
    measured perpendicular to it; planes whose normals differ give none); for the width
    (length) of a slot (``OppositeParallelLines``), the direction across (along) its
    centre line in the plane of its normal.  Sizes (diameter, radius), positions and form
    tolerances have no single axis: ``""``, as has a vector more than 5° from every axis.
    """
    ns = owner.ns
    word = child_text(nom, ns, "Direction")
    if word:
        return axis_word(word)
    analysis = _child(nom, ns, "AnalysisVector")
    if analysis is not None:
        return vector_axis(_vector(analysis))
    features = _features(item, owner)
    if kind == "PointProfile":
        # An edge point's deviation may be along its Normal or its AdjacentNormal: not stated, so none.
        surface = len(features) == 1 and features[0] is not None and local(features[0].tag) in _SURFACES
        return vector_axis(_vector(_child(features[0], ns, "Normal"))) if surface else ""
    if kind in _DISTANCES:
        planes = {
            vector_axis(_vector(_child(f, ns, "Normal")))
            for f in features
            if f is not None and local(f.tag) == "PlaneFeatureNominal"
        }
        return planes.pop() if len(planes) == 1 else ""
    if (
        kind in ("Width", "Length")
        and len(features) == 1
        and features[0] is not None
        and local(features[0].tag) == "OppositeParallelLinesFeatureNominal"
    ):
        normal = _unit(_vector(_child(features[0], ns, "Normal")))
        along = _unit(_vector(features[0].find(f"{{{ns}}}CenterLine/{{{ns}}}Vector")))
        if normal is None or along is None:
            return ""
        across = cross(normal, along)
        if math.sqrt(sum(v * v for v in across)) < AXIS_COSINE:
            return ""  # the centre line is not in the plane of the normal: no width direction stated
        return vector_axis(across if kind == "Width" else along)
    return ""


#: Feature nominal element → the ``feature`` word (:mod:`parsers.geometry`).
_FEATURE_WORDS = {
    "PointFeatureNominal": "point",
    "EdgePointFeatureNominal": "edgepoint",
    "PlaneFeatureNominal": "plane",
    "LineFeatureNominal": "line",
    "CircleFeatureNominal": "circle",
    "CircularArcFeatureNominal": "arc",
    "CylinderFeatureNominal": "cylinder",
    "ConeFeatureNominal": "cone",
    "SphereFeatureNominal": "sphere",
    "OppositeParallelLinesFeatureNominal": "slot",
    "OppositeParallelPlanesFeatureNominal": "slot",
    "TorusFeatureNominal": "torus",
}
#: Characteristic kinds that are a size of their feature → the ``size`` word.
_SIZE_KINDS = {
    "Diameter": "diameter",
    "SphericalDiameter": "diameter",
    "Radius": "radius",
    "SphericalRadius": "radius",
    "Width": "width",
}


def item_geometry(
    kind: str, item: etree._Element, nom: etree._Element, owner: Doc
) -> tuple[tuple[float, float, float] | None, str, str, str]:
    """(measuring direction, feature, size, side) of a characteristic, as :mod:`parsers.geometry` defines them.

    The direction follows :func:`item_axis` but keeps the vector (an oblique one too):
    the ``Direction`` word's unit vector, the ``AnalysisVector``, a point profile's
    surface normal, the common normal of a distance's planes (when they are parallel
    within 5°), a slot's across (width) or along (length) direction.  The feature is
    the type of the item's first feature nominal; the side its definition's
    ``InternalExternal``.
    """
    ns = owner.ns
    features = _features(item, owner)
    first = features[0] if features else None
    feature = _FEATURE_WORDS.get(local(first.tag), "") if first is not None else ""
    size = _SIZE_KINDS.get(kind, "")
    if kind == "Length" and feature == "slot":
        size = "length"
    side = ""
    if first is not None:
        definition = owner.index.local.get(child_text(first, ns, "FeatureDefinitionId"))
        side = {"INTERNAL": "inner", "EXTERNAL": "outer"}.get(child_text(definition, ns, "InternalExternal"), "")
    direction: tuple[float, float, float] | None = None
    word = child_text(nom, ns, "Direction")
    analysis = _child(nom, ns, "AnalysisVector")
    if word:
        direction = axis_vector(axis_word(word))
    elif analysis is not None:
        direction = unit_vector(_vector(analysis))
    elif kind == "PointProfile":
        if len(features) == 1 and first is not None and local(first.tag) in _SURFACES:
            direction = unit_vector(_vector(_child(first, ns, "Normal")))
    elif kind in _DISTANCES:
        normals = [
            unit_vector(_vector(_child(f, ns, "Normal")))
            for f in features
            if f is not None and local(f.tag) == "PlaneFeatureNominal"
        ]
        if normals and all(n is not None for n in normals):
            head = normals[0]
            assert head is not None
            if all(
                abs(sum(a * b for a, b in zip(head, n, strict=True))) >= AXIS_COSINE for n in normals if n is not None
            ):
                direction = head
    elif kind in ("Width", "Length") and feature == "slot" and first is not None:
        normal = _unit(_vector(_child(first, ns, "Normal")))
        along = _unit(_vector(first.find(f"{{{ns}}}CenterLine/{{{ns}}}Vector")))
        if normal is not None and along is not None:
            across = cross(normal, along)
            if math.sqrt(sum(v * v for v in across)) >= AXIS_COSINE:
                direction = unit_vector(across if kind == "Width" else along)
    return direction, feature, size, side


def _limits(
    kind: str, definition: etree._Element, owner: Doc, nominal: float, mm: float, notes: set[str]
) -> tuple[float, float, bool] | None:
    """(lower, upper, reference) as signed deviations; None when the nominal is needed but absent."""
    ns, path = owner.ns, owner.path
    if _child(definition, ns, "NonTolerance") is not None:
        return math.nan, math.nan, True
    zone = _child(definition, ns, "ToleranceValue")
    if zone is not None:
        size = number(zone, path, mm)
        if size < 0:
            # Origin CheckMate writes a perpendicularity zone as -0.13 while the part passes
            # (NIST_MTC_Incoming_PlateResults_20_samples.QIF): a zone width has no sign.
            notes.add(f"negative tolerance zone {size:g} read as {-size:g} (line {zone.sourceline})")
            size = -size
        if kind in PROFILE_KINDS:
            outer = _child(definition, ns, "OuterDisposition")
            if outer is not None:
                upper = number(outer, path, mm)
                return upper - size, upper, False
            return -size / 2, size / 2, False
        return math.nan, size, False
    tol = _child(definition, ns, "Tolerance")
    ref = child_text(tol, ns, "DefinitionId")
    if ref:
        tol = owner.index.local.get(ref, tol)
    if tol is None:
        return math.nan, math.nan, False
    upper, lower = number(_child(tol, ns, "MaxValue"), path, mm), number(_child(tol, ns, "MinValue"), path, mm)
    if child_text(tol, ns, "DefinedAsLimit").lower() in ("true", "1"):
        if math.isnan(nominal):
            return None
        upper, lower = upper - nominal, lower - nominal
    return lower, upper, False


@dataclass(frozen=True)
class Item:
    """What every measurement of one characteristic item shares (lengths in mm)."""

    label: str
    nominal: float
    lower: float
    upper: float
    reference: bool
    x: float
    y: float
    z: float
    axis: str
    #: The geometry columns (:mod:`parsers.geometry`): measuring direction, feature type, size, side.
    nx: float = math.nan
    ny: float = math.nan
    nz: float = math.nan
    feature: str = ""
    size: str = ""
    side: str = ""


def item_info(
    kind: str,
    item: etree._Element,
    nom: etree._Element,
    definition: etree._Element,
    owner: Doc,
    doc: Doc,
    mm: float,
    notes: set[str],
) -> Item | str:
    """Name, nominal, limits and location of one item; a skip reason when it has no nominal."""
    omm = mm if owner is doc else owner_mm(owner, mm)
    geometric = _child(definition, owner.ns, "ToleranceValue") is not None
    nominal = (
        0.0 if geometric or kind in PROFILE_KINDS else number(_child(nom, owner.ns, "TargetValue"), owner.path, omm)
    )
    x, y, z = _location(item, owner, omm)
    if math.isnan(nominal) and kind == "LinearCoordinate":
        # A coordinate dimension may leave its target to the feature's nominal location.
        nominal = {"XAXIS": x, "YAXIS": y, "ZAXIS": z}.get(child_text(nom, owner.ns, "Direction"), math.nan)
    limits = _limits(kind, definition, owner, nominal, omm, notes)
    if math.isnan(nominal) or limits is None:
        return "without a nominal value"
    lower, upper, reference = limits
    if not math.isnan(lower) and not math.isnan(upper) and lower > upper:
        raise ParseError(
            f"lower limit {lower:g} mm is above upper limit {upper:g} mm",
            location=SourceLocation(
                owner.path, line=definition.sourceline, element=f"{local(definition.tag)} id={definition.get('id')}"
            ),
        )
    label = (
        child_text(item, owner.ns, "Name")
        or child_text(definition, owner.ns, "Name")
        or f"{kind} {item.get('id', '?')}"
    )
    direction, feature, size, side = item_geometry(kind, item, nom, owner)
    nx, ny, nz = direction if direction is not None else (math.nan, math.nan, math.nan)
    return Item(
        label,
        nominal,
        lower,
        upper,
        reference,
        x,
        y,
        z,
        item_axis(kind, item, nom, owner),
        nx,
        ny,
        nz,
        feature,
        size,
        side,
    )


def raw_float(text: str) -> float:
    value = try_number(text)
    return math.nan if value is None else value


def owner_mm(owner: Doc, fallback: float) -> float:
    """mm per file unit of ``owner`` (a plan the results refer to): its own ``FileUnits``, else ``fallback``."""
    declared = file_unit_factor(owner.root, owner.ns, owner.path)
    return fallback if declared is None else declared
