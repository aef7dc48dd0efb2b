"""The features a QIF measurement is of: nominal and actual position, own direction, names, datums.

One measurement (``…CharacteristicActual`` / ``…CharacteristicMeasurement``) names the
actual features it was evaluated on (``FeatureActualIds``, or ``FeatureMeasurementIds``);
each actual feature names its feature item (``FeatureItemId``), which names its nominal
(``FeatureNominalId``).  A measurement that names none (the QIF 3 samples) is of the
features of its characteristic item (``FeatureItemIds``), measured in the same
``MeasurementResults``.  One item measured on several features (the four holes of
``DIAMETER2`` in the NIST cover) thus gets each hole's own position.

What a row gets (the columns of :mod:`setupfix.model.measurements`):

- ``x, y, z`` / ``x_actual, y_actual, z_actual``: the feature's ``Location`` (a point,
  plane, circle, sphere, line), its axis point (``Axis/AxisPoint``: a cylinder, a cone)
  or its centre line's start (``CenterLine/StartPoint``: a slot), nominal and actual, mm;
- ``feature_nx, feature_ny, feature_nz``: the nominal feature's own direction as a unit
  vector: a cylinder's or cone's ``Axis/Direction``, a line's ``Direction``, else its
  ``Normal``.  A stated direction whose length is not 1 (within 0.1 %) is not a direction:
  a writer that swapped ``Location`` and ``Normal`` (``QIF2.1_Results_Sample.QIF``'s
  circles) gives neither, with a note;
- ``feature_id`` (one feature) or ``between`` (two or more, ``"id1;id2"`` in the
  measurement's order): each feature's ``FeatureName``, else ``#<feature item id>``;
- ``datums``: the definition's (else the nominal's) ``DatumReferenceFrameId`` →
  ``Datums/Datum`` in precedence order, each the ``DatumLabel`` of its datum definition
  (a compound datum's labels joined by ``-``), joined by ``|``.

A ``FeatureActualIds`` entry (or its ``FeatureItemId``) that points nowhere leaves all the
feature columns of the row empty, its nominal location too (the item's first feature may
be another one of the features it is measured on), never an error: the value and limits
of the row are still right without them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from lxml import etree

from parsers.numbers import try_number
from parsers.qif.items import Doc, child_text, local

__all__ = ["FeatureGeometry", "ResultsFeatures", "measurement_features", "datum_labels", "NO_FEATURES", "BROKEN"]

#: Largest departure of a stated unit vector's length from 1 that is still read as a direction.
UNIT_TOLERANCE = 1e-3

_Point = tuple[float, float, float]
_NAN3: _Point = (math.nan, math.nan, math.nan)


@dataclass(frozen=True)
class FeatureGeometry:
    """The feature columns of one measurement (lengths in mm; NaN / "" where not stated)."""

    nominal: _Point = _NAN3
    actual: _Point = _NAN3
    direction: _Point = _NAN3
    feature_id: str = ""
    between: str = ""
    #: Whether a feature's Location/Normal looked swapped (its positions and direction left out).
    swapped: bool = False
    #: Whether the measurement names an actual feature (or that one a feature item) that is not in the
    #: file: nothing about its feature is known, not even the item's location.
    broken: bool = False


#: A measurement of no stated feature (its item's location, if any, stands).
NO_FEATURES = FeatureGeometry()
#: A measurement whose feature ids point nowhere.
BROKEN = FeatureGeometry(broken=True)


class ResultsFeatures:
    """The actual features of one ``MeasurementResults``, by id and by feature item id (read once)."""

    def __init__(self, results: etree._Element, ns: str) -> None:
        self.by_id: dict[str, etree._Element] = {}
        self.by_item: dict[str, etree._Element] = {}
        # QIF 2: MeasuredFeatures/FeatureActuals/*; QIF 3: the features are MeasuredFeatures' children.
        for child in results.iterfind(f"{{{ns}}}MeasuredFeatures/*"):
            group = [child] if child.find(f"{{{ns}}}FeatureItemId") is not None else list(child)
            for feature in group:
                if not isinstance(feature.tag, str):
                    continue
                ident = (feature.get("id") or "").strip()
                if ident:
                    self.by_id.setdefault(ident, feature)
                item = child_text(feature, ns, "FeatureItemId")
                if item:
                    self.by_item.setdefault(item, feature)


def _triple(el: etree._Element | None, scale: float) -> _Point | None:
    """Three numbers of a point or vector element (times ``scale``); None when absent or not three numbers."""
    words = (el.text or "").split() if el is not None else []
    if len(words) != 3:
        return None
    values = [try_number(w, scale=scale) for w in words]
    if any(v is None for v in values):
        return None
    return (float(values[0]), float(values[1]), float(values[2]))  # type: ignore[arg-type]  # no None: tested


#: Where a feature element states its position, in order of preference.
_POSITION_PATHS = ("Location", "Axis/AxisPoint", "CenterLine/StartPoint")


def _position(feature: etree._Element | None, ns: str, scale: float) -> _Point | None:
    if feature is None:
        return None
    for path in _POSITION_PATHS:
        found = feature.find("/".join(f"{{{ns}}}{p}" for p in path.split("/")))
        if found is not None:
            return _triple(found, scale)
    return None


def _direction(feature: etree._Element | None, ns: str) -> tuple[_Point | None, bool]:
    """(unit direction, whether a stated one was not a unit vector) of a nominal feature."""
    if feature is None:
        return None, False
    paths = (
        ("Direction", "Normal") if local(feature.tag).startswith("Line") else ("Axis/Direction", "Normal", "Direction")
    )
    for path in paths:
        found = feature.find("/".join(f"{{{ns}}}{p}" for p in path.split("/")))
        if found is None:
            continue
        vector = _triple(found, 1.0)
        if vector is None:
            return None, False
        norm = math.sqrt(sum(v * v for v in vector))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            return None, True
        return (vector[0] / norm + 0.0, vector[1] / norm + 0.0, vector[2] / norm + 0.0), False
    return None, False


def _name(item: etree._Element | None, ident: str, ns: str) -> str:
    name = child_text(item, ns, "FeatureName") if item is not None else ""
    return name or f"#{ident}"


def measurement_features(
    actual_ids: Sequence[str],
    item: etree._Element,
    results: ResultsFeatures,
    doc: Doc,
    owner: Doc,
    mm: float,
    owner_mm: float,
) -> FeatureGeometry:
    """The feature columns of one measurement (see the module docstring).

    Parameters
    ----------
    actual_ids : sequence of str
        The measurement's ``FeatureActualIds`` (or ``FeatureMeasurementIds``), in order; empty
        when it names none (then the item's ``FeatureItemIds`` measured in the same results).
    item : Element
        The characteristic item.
    results : ResultsFeatures
        The actual features of the measurement's ``MeasurementResults``.
    doc, owner : Doc
        The results document and the one holding the item (a plan for external references).
    mm, owner_mm : float
        mm per file unit of each.
    """
    ns = doc.ns
    pairs: list[tuple[str, etree._Element | None, etree._Element | None]] = []  # (item id, item, actual)
    if actual_ids:
        for ident in actual_ids:
            actual = results.by_id.get(ident)
            item_id = child_text(actual, ns, "FeatureItemId") if actual is not None else ""
            feature_item = doc.index.local.get(item_id) if item_id else None
            if feature_item is None and item_id:
                feature_item = owner.index.local.get(item_id)
            if feature_item is None:
                return BROKEN  # an id that points nowhere: which feature this is, the file does not say
            pairs.append((item_id, feature_item, actual))
    else:
        for ref in item.iterfind(f"{{{owner.ns}}}FeatureItemIds/{{{owner.ns}}}Id"):
            item_id = (ref.text or "").strip()
            feature_item = owner.index.local.get(item_id)
            if feature_item is None:
                return BROKEN
            pairs.append((item_id, feature_item, results.by_item.get(item_id)))
    if not pairs:
        return NO_FEATURES
    names = [_name(feature_item, ident, owner.ns) for ident, feature_item, _ in pairs]
    _, first_item, first_actual = pairs[0]
    nominal_el = (
        owner.index.local.get(child_text(first_item, owner.ns, "FeatureNominalId")) if first_item is not None else None
    )
    if nominal_el is None and first_item is not None:
        nominal_el = doc.index.local.get(child_text(first_item, ns, "FeatureNominalId"))
    direction, swapped = _direction(nominal_el, owner.ns)
    if not swapped and first_actual is not None:
        swapped = _direction(first_actual, ns)[1]
    nominal = None if swapped else _position(nominal_el, owner.ns, owner_mm)
    actual = None if swapped else _position(first_actual, ns, mm)
    return FeatureGeometry(
        nominal=nominal or _NAN3,
        actual=actual or _NAN3,
        direction=direction or _NAN3,
        feature_id=names[0] if len(names) == 1 else "",
        between=";".join(names) if len(names) > 1 else "",
        swapped=swapped,
    )


_PRECEDENCE = {"PRIMARY": 0, "SECONDARY": 1, "TERTIARY": 2}


def datum_labels(definition: etree._Element, nominal: etree._Element, owner: Doc) -> str:
    """The datum reference frame of a characteristic as ``"A|B|C"`` ("" when it names none)."""
    ns, ids = owner.ns, owner.index.local
    frame_id = child_text(definition, ns, "DatumReferenceFrameId") or child_text(nominal, ns, "DatumReferenceFrameId")
    frame = ids.get(frame_id) if frame_id else None
    if frame is None:
        return ""
    datums: list[tuple[int, int, str]] = []
    for order, datum in enumerate(frame.iterfind(f"{{{ns}}}Datums/{{{ns}}}Datum")):
        labels = []
        for ref in datum.iter(f"{{{ns}}}DatumDefinitionId"):
            ident = (ref.text or "").strip()
            labels.append(child_text(ids.get(ident), ns, "DatumLabel") or f"#{ident}")
        if not labels:
            continue
        rank = _PRECEDENCE.get(child_text(datum.find(f"{{{ns}}}Precedence"), ns, "PrecedenceEnum"), len(_PRECEDENCE))
        datums.append((rank, order, "-".join(labels)))
    return "|".join(label for _, _, label in sorted(datums))
