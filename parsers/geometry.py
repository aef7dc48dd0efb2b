"""The geometry a report states per characteristic: the optional columns ``nx, ny, nz, feature, size, side``.

Beside the ``axis`` column (:mod:`parsers.axes`), readers of formats that state more add
these columns to the canonical table (the contract keeps unknown columns; no other
code than ``setupfix model init`` reads them):

``nx, ny, nz``
    The unit vector along which the characteristic's value grows when its feature moves
    (its measuring direction): a DMIS ``CORTOL`` axis word or QIF ``Direction`` as the
    axis' unit vector, a QIF ``AnalysisVector``, the nominal surface normal of a point or
    plane a point-profile deviation is measured along, the common normal of the planes
    a distance is measured between, the direction across (along) a slot for its width
    (length).  NaN where the report states none; never a guess.
``feature``
    The type of the characteristic's feature as the report states it, one word of
    :data:`FEATURES` (``""`` when not stated).
``size``
    ``"diameter"``, ``"radius"``, ``"width"`` or ``"length"`` (of a slot) when the value
    is a size of its feature — moved by no translation, only by a tool radius where the
    feature is cut by interpolation (:data:`INTERPOLATED`); ``""`` otherwise.
``side``
    ``"inner"`` (a bore, a slot) or ``"outer"`` (a boss, a rib) where the report says so,
    else ``""``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = [
    "DIRECTION_COLUMNS",
    "FEATURE_COLUMN",
    "SIZE_COLUMN",
    "SIDE_COLUMN",
    "GEOMETRY_COLUMNS",
    "FEATURES",
    "SIZES",
    "INTERPOLATED",
    "unit_vector",
    "axis_vector",
    "geometry_cells",
    "no_geometry",
]

DIRECTION_COLUMNS = ("nx", "ny", "nz")
FEATURE_COLUMN = "feature"
SIZE_COLUMN = "size"
SIDE_COLUMN = "side"
GEOMETRY_COLUMNS = (*DIRECTION_COLUMNS, FEATURE_COLUMN, SIZE_COLUMN, SIDE_COLUMN)

#: Feature types, as the ``feature`` column spells them.
FEATURES = ("point", "edgepoint", "plane", "line", "circle", "arc", "cylinder", "cone", "sphere", "slot", "torus")
#: What a size characteristic measures.
SIZES = ("diameter", "radius", "width", "length")
#: Features whose sizes a milling tool cuts by moving round (circle, arc, cylinder: circular
#: interpolation) or along them (the sides of a slot): their sizes move with the tool's
#: radius offset.  A size of any other feature (a sphere, a cone, a drilled or reamed hole
#: the report gives no feature type for) moves with no offset register.
INTERPOLATED = frozenset({"circle", "arc", "cylinder", "slot"})

_AXES = ("X", "Y", "Z")


def unit_vector(vector: Sequence[float] | None) -> tuple[float, float, float] | None:
    """``vector`` scaled to length 1; None for a missing, zero, non-finite or not-3 vector."""
    if vector is None or len(vector) != 3 or not all(math.isfinite(v) for v in vector):
        return None
    norm = math.sqrt(sum(v * v for v in vector))
    if norm == 0.0:
        return None
    return (vector[0] / norm + 0.0, vector[1] / norm + 0.0, vector[2] / norm + 0.0)


def axis_vector(axis: str) -> tuple[float, float, float] | None:
    """The unit vector of ``"X"``, ``"Y"`` or ``"Z"``; None for anything else (``""``)."""
    if axis not in _AXES:
        return None
    return tuple(1.0 if a == axis else 0.0 for a in _AXES)  # type: ignore[return-value]  # three items


def geometry_cells(
    direction: Sequence[float] | None = None, feature: str = "", size: str = "", side: str = ""
) -> dict[str, object]:
    """The geometry columns of one row (``nx, ny, nz`` NaN without a direction)."""
    unit = unit_vector(direction)
    nx, ny, nz = unit if unit is not None else (math.nan, math.nan, math.nan)
    return {"nx": nx, "ny": ny, "nz": nz, FEATURE_COLUMN: feature, SIZE_COLUMN: size, SIDE_COLUMN: side}


def no_geometry() -> dict[str, object]:
    """The geometry columns of a row whose report states none."""
    return geometry_cells()
