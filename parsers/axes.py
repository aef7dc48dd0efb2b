"""The machine axis a report states for a characteristic: the optional ``axis`` column.

The canonical table may carry an ``axis`` column (``"X"``, ``"Y"``, ``"Z"`` or ``""``;
the contract keeps unknown columns): the axis along which the characteristic's value
is measured, as the report states it — a DMIS ``CORTOL`` axis word, a QIF
``LinearCoordinate`` direction or ``AnalysisVector``, the normal of the surface a
point-profile deviation or a distance to a plane is measured along.  Readers of
formats that state no direction leave the column out; a characteristic whose
direction is oblique, or not stated, gets ``""`` — never a guess.

A vector is *along* a machine axis when it is within :data:`AXIS_ANGLE_DEG` = 5° of
it, i.e. its component on that axis is at least cos 5° = 0.9962 of its length.  Why
5°: an offset along that axis then moves the value by at least 99.6 % of the offset,
and an offset along another axis by at most sin 5° = 8.7 % of it; the 10°-tilted face
of the QIF widget sample (normal 0, 0.985, 0.174) would move 17 % with Z and is
reported oblique.  Nominal vectors of machined prismatic parts are exact to 1e-14 in
every sample, so the threshold only separates truly tilted features.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = ["AXIS_COLUMN", "AXES", "AXIS_ANGLE_DEG", "AXIS_COSINE", "vector_axis", "axis_word", "cross"]

#: Name of the optional column of the canonical table.
AXIS_COLUMN = "axis"
AXES = ("X", "Y", "Z")
#: Largest angle between a vector and a machine axis for the vector to be along that axis [deg].
AXIS_ANGLE_DEG = 5.0
AXIS_COSINE = math.cos(math.radians(AXIS_ANGLE_DEG))

_WORDS = {"XAXIS": "X", "YAXIS": "Y", "ZAXIS": "Z"}


def vector_axis(vector: Sequence[float] | None) -> str:
    """The machine axis a direction vector lies along (either sense), else ``""``.

    Parameters
    ----------
    vector : sequence of 3 floats, or None
        Any length; a zero, non-finite or missing vector gives ``""``.

    Returns
    -------
    str
        ``"X"``, ``"Y"`` or ``"Z"`` when ``|v_axis| ≥ cos 5° · |v|``; ``""`` when the vector
        is oblique (more than :data:`AXIS_ANGLE_DEG` from every axis).
    """
    if vector is None or len(vector) != 3 or not all(math.isfinite(v) for v in vector):
        return ""
    norm = math.sqrt(sum(v * v for v in vector))
    if norm == 0.0:
        return ""
    best = max(range(3), key=lambda i: abs(vector[i]))
    return AXES[best] if abs(vector[best]) >= AXIS_COSINE * norm else ""


def axis_word(word: str) -> str:
    """``XAXIS`` / ``YAXIS`` / ``ZAXIS`` (any case) → ``X`` / ``Y`` / ``Z``; any other word → ``""``."""
    return _WORDS.get(word.strip().upper(), "")


def cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """The cross product a × b of two 3-vectors."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
