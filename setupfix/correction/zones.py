"""Circular position zones (``../shared/spec/process-model.md``, *Multi-axis models*) as linear rows.

A zone's margin is R − ‖δ + d‖ (δ its measured component deviations along its two plane axes, d
their changes, R the radius): not linear in the corrections.  The problem builder
(:meth:`setupfix.optimize.CorrectionProblem.from_part`) replaces it by the k facets of the regular
k-gon inscribed in the circle, n_j · (δ + d) / cos(π/k) ≤ R, so every optimiser solves it as
one-sided linear rows; :class:`Circles` keeps the zones themselves so that every margin shown is
the circle's (:func:`zone_margins`).  A CMM prints a position as a diameter, twice the radial
distance (:func:`cmm_position`); the margin stays radial.  The polygon margin min_j (R − n_j·v / cos(π/k)) lies in
[R − ‖v‖/cos(π/k), R − ‖v‖]: the error is at most ‖v‖ (1/cos(π/k) − 1) (:func:`polygon_sides`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "ZONE_TOLERANCE_MM",
    "MAX_SIDES",
    "Circles",
    "polygon_sides",
    "facet_rows",
    "zone_margins",
    "polygon_error",
    "cmm_position",
]

Array = npt.NDArray[np.float64]

#: Largest error of a position zone's polygon margin against the circle's [mm] (issue 23: ≤ 1 µm).
ZONE_TOLERANCE_MM = 0.001
#: Most facets a zone is given (reached only for deviations ~100 mm beyond a zone of 0.1 mm).
MAX_SIDES = 4096


def polygon_sides(reach: float, tolerance: float) -> int:
    """Least k ≥ 8 with reach · (1/cos(π/k) − 1) ≤ tolerance (at most :data:`MAX_SIDES`).

    ``reach`` [unit] bounds the radial distance ‖v‖ where the bound must hold.
    """
    if reach <= 0:
        return 8
    angle = float(np.arccos(1.0 / (1.0 + tolerance / reach)))  # 1/cos(a) − 1 = tol/reach
    return int(min(MAX_SIDES, max(8, np.ceil(np.pi / angle))))


def facet_rows(component_dev: Array, component_comp: Array, sides: int) -> tuple[Array, Array]:
    """The k facet rows of one zone: n_j · (δ + d) / cos(π/k) ≤ R.

    Parameters
    ----------
    component_dev : ndarray of shape (2,)
        δ, the zone's measured component deviations [unit].
    component_comp : ndarray of shape (n_registers, 2)
        Change of each component per unit of each register.
    sides : int
        k.

    Returns
    -------
    deviation : ndarray of shape (k,)
        n_j · δ / cos(π/k).
    composite : ndarray of shape (n_registers, k)
        n_j · c_r / cos(π/k).
    """
    angle = 2.0 * np.pi * np.arange(sides) / sides
    normals = np.stack([np.cos(angle), np.sin(angle)], axis=1) / np.cos(np.pi / sides)  # (k, 2)
    return normals @ component_dev, component_comp @ normals.T


def zone_margins(component_dev: Array, component_comp: Array, x: Array, radius: Array) -> Array:
    """True margins R − ‖δ + x · c‖ of position zones (spec, *Multi-axis models*).

    Parameters
    ----------
    component_dev : ndarray of shape (n_zones, 2) [unit]
    component_comp : ndarray of shape (n_registers, n_zones, 2)
    x : ndarray of shape (n_registers,) [problem units, i.e. register values]
    radius : ndarray of shape (n_zones,) [unit]

    Returns
    -------
    ndarray of shape (n_zones,) [unit]
    """
    moved = component_dev + np.einsum("r,rzk->zk", np.asarray(x, dtype=float), component_comp)
    out: Array = radius - np.hypot(moved[:, 0], moved[:, 1])
    return out


def cmm_position(distance: npt.ArrayLike) -> Array:
    """A position zone's value as a CMM report prints it: the diameter 2‖δ‖ of the circle, centred
    on the true position, on which the feature lies (ISO 1101 position; compared with the zone's
    diameter, as the radial distance ‖δ‖ is with its radius).

    Parameters
    ----------
    distance : array_like of any shape
        Radial distances ‖δ‖ ≥ 0 [unit].

    Returns
    -------
    ndarray of the same shape [unit]
    """
    out: Array = 2.0 * np.asarray(distance, dtype=float)
    return out


def polygon_error(reach: float, sides: int) -> float:
    """Bound reach · (1/cos(π/k) − 1) on circle margin − polygon margin for ‖v‖ ≤ reach [unit]."""
    return float(reach * (1.0 / np.cos(np.pi / sides) - 1.0))


@dataclass(frozen=True)
class Circles:
    """The position zones of a problem, kept beside their facet rows.

    Attributes
    ----------
    ids : tuple of str
        Zone (model dimension) IDs.
    deviation : ndarray of shape (n_zones, 2) [unit]
        Measured component deviations δ.
    composite : ndarray of shape (n_registers, n_zones, 2)
        Change of each component per problem unit of each register.
    radius : ndarray of shape (n_zones,) [unit]
    sides : tuple of int
        Facets of each zone's polygon.
    """

    ids: tuple[str, ...]
    deviation: Array
    composite: Array
    radius: Array
    sides: tuple[int, ...]

    def distance(self, x: Array) -> Array:
        """Radial distance ‖δ + x · c‖ of each zone after problem vector x, shape (n_zones,) [unit]."""
        moved = self.deviation + np.einsum("r,rzk->zk", np.asarray(x, dtype=float), self.composite)
        out: Array = np.hypot(moved[:, 0], moved[:, 1])
        return out

    def margins(self, x: Array) -> Array:
        """True margins R − ‖δ + x · c‖, shape (n_zones,) [unit]."""
        return zone_margins(self.deviation, self.composite, x, self.radius)
