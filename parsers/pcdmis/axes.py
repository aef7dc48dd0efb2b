"""PC-DMIS axis letters that are not lengths (Hexagon help, *Location Axes*)."""

from __future__ import annotations

from typing import Final

__all__ = ["ANGLE_AXES", "NON_LENGTH_AXES"]

#: Angles: A (angle dimension, vector angle), PA (polar angle), and the NC Gage "Angle" row.
ANGLE_AXES: Final[frozenset[str]] = frozenset({"A", "PA", "ANGLE", "ANG"})
#: Other non-length values: AR (area).
NON_LENGTH_AXES: Final[frozenset[str]] = frozenset({"AR", "AREA"})
