"""Decisions under measurement uncertainty: ISO 14253-1 verdicts, vectorised.

ISO 14253-1 proves that a characteristic conforms only when its measured value lies in the
*conformance zone*, the tolerance shrunk by the expanded uncertainty U (k = 2) at each
limit, and proves that it does not conform only when the value lies outside the tolerance
widened by U; between the two nothing is proven.  With U = 0 the three cases reduce to
"inside the tolerance" (conforming) and "outside" (nonconforming).  A one-sided tolerance
(an infinite limit) has no zone boundary on that side.  A circular position zone is judged
on its radial distance r ≥ 0 against its radius R: conforming r ≤ R − U, nonconforming
r > R + U (its lower limit 0 is no tolerance limit).

:func:`dimension_uncertainty` gives each model dimension's U and where it comes from, in
the precedence of :mod:`setupfix.model.safety` (the report's own value first).
"""

from __future__ import annotations

from typing import Any, Final

import numpy as np
import numpy.typing as npt

from setupfix.model import PartMeasurement, ProcessModel

__all__ = [
    "CONFORMING",
    "NOT_PROVEN",
    "NONCONFORMING",
    "VERDICT_NAMES",
    "TOLERANCE",
    "conformance_codes",
    "conformance_names",
    "conformance_zone",
    "report_uncertainty",
    "dimension_uncertainty",
    "conformance_rows",
]

Array = npt.NDArray[np.float64]

CONFORMING: Final = "conforming"
NOT_PROVEN: Final = "not_proven"
NONCONFORMING: Final = "nonconforming"
#: The verdict of each code of :func:`conformance_codes` (code −1, not measured, is "").
VERDICT_NAMES: Final[tuple[str, str, str]] = (CONFORMING, NOT_PROVEN, NONCONFORMING)
#: Rounding allowance [model unit] of a limit comparison (as the "in tolerance" flags use).
TOLERANCE: Final = 1e-12


def conformance_codes(
    value: npt.ArrayLike,
    lower: npt.ArrayLike,
    upper: npt.ArrayLike,
    uncertainty: npt.ArrayLike,
    zone: npt.ArrayLike | None = None,
) -> npt.NDArray[np.int8]:
    """ISO 14253-1 verdict codes: 0 conforming, 1 not proven, 2 nonconforming, −1 not measured (NaN).

    conforming      lower + U ≤ v ≤ upper − U
    nonconforming   v < lower − U  or  v > upper + U
    not proven      otherwise (also wherever the conformance zone is empty, 2U ≥ upper − lower)

    Each comparison allows :data:`TOLERANCE` so that U = 0 gives exactly "in tolerance".

    Parameters
    ----------
    value : ndarray of shape (..., n) [model unit]
        Deviations from nominal (a zone: the radial distance ≥ 0).
    lower, upper : ndarray of shape (n,) [model unit]
        Tolerance limits as signed deviations (±inf: one-sided; a zone: 0 and its radius).
    uncertainty : ndarray of shape (n,) or (..., n) [model unit]
        Expanded uncertainty U ≥ 0 (k = 2).
    zone : bool ndarray of shape (n,), optional
        Circular position zones: their lower limit is ignored.

    Returns
    -------
    int8 ndarray of the broadcast shape (..., n)
    """
    v = np.asarray(value, dtype=np.float64)
    u = np.asarray(uncertainty, dtype=np.float64)
    lo = np.asarray(lower, dtype=np.float64)
    up = np.asarray(upper, dtype=np.float64)
    if zone is not None:
        lo = np.where(np.asarray(zone, dtype=bool), -np.inf, lo)
    with np.errstate(invalid="ignore"):
        inside = (v >= lo + u - TOLERANCE) & (v <= up - u + TOLERANCE)
        outside = (v < lo - u - TOLERANCE) | (v > up + u + TOLERANCE)
    codes = np.where(inside, 0, np.where(outside, 2, 1)).astype(np.int8)
    return np.where(np.isnan(v), np.int8(-1), codes).astype(np.int8)


def conformance_names(codes: npt.NDArray[np.int8]) -> list[str]:
    """The JSON spelling of 1-D verdict codes ("conforming", "not_proven", "nonconforming"; "" not measured)."""
    return [VERDICT_NAMES[c] if c >= 0 else "" for c in np.asarray(codes).tolist()]


def conformance_zone(lower: Array, upper: Array, uncertainty: Array) -> tuple[Array, Array, npt.NDArray[np.bool_]]:
    """The conformance zone [lower + U, upper − U] and where it is empty (2U ≥ upper − lower).

    lower, upper, uncertainty : ndarray of shape (n,) [model unit]
    → zone lower, zone upper : shape (n,) [model unit]; empty : bool shape (n,)
    """
    lo = np.asarray(lower, dtype=np.float64) + uncertainty
    up = np.asarray(upper, dtype=np.float64) - uncertainty
    with np.errstate(invalid="ignore"):
        empty = (np.asarray(uncertainty) > 0) & ~(lo < up)
    return lo, up, empty


def report_uncertainty(part: PartMeasurement) -> Array | None:
    """The report's own U of each model dimension (model unit, NaN where not given), or None.

    Read from ``PartMeasurement.uncertainty`` (the canonical ``uncertainty`` column,
    ``../shared/spec/measurements.md``, matched to the model's dimensions).
    """
    if part.uncertainty is None:
        return None
    values = np.asarray(part.uncertainty, dtype=np.float64)
    if values.shape != np.shape(part.deviation) or not np.isfinite(values).any():
        return None
    return np.where(np.isfinite(values) & (values >= 0), values, np.nan)


def dimension_uncertainty(model: ProcessModel, part: PartMeasurement | None = None) -> tuple[Array, tuple[str, ...]]:
    """Each model dimension's U [model unit] and its source, in model order.

    The report's value (``part``, :func:`report_uncertainty`) wins; else the model's
    (:meth:`setupfix.model.safety.SafetySettings.source_of`: "dimension", "measurement",
    "mpe"); else 0 with source "".

    Returns
    -------
    u : ndarray of shape (n_dimensions,) [model unit]
    sources : tuple of str, length n_dimensions
    """
    s = model.safety
    ids = [d.id for d in model.dimensions]
    model_u = np.array([s.dimension_uncertainty.get(d, s.uncertainty) for d in ids], dtype=np.float64)
    sources = [s.source_of(d) if u > 0 else "" for d, u in zip(ids, model_u, strict=True)]
    given = report_uncertainty(part) if part is not None else None
    if given is None:
        return model_u, tuple(sources)
    own = np.isfinite(given)
    u = np.where(own, given, model_u)
    return u, tuple("report" if o else src for o, src in zip(own.tolist(), sources, strict=True))


def conformance_rows(
    model: ProcessModel, part: PartMeasurement | None, rows: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Dimension rows (``id``, ``deviation``, ``predicted``) with U, its source and the verdicts before and after.

    Adds ``uncertainty`` [model unit] (0 where none), ``uncertainty_source``
    (:data:`setupfix.model.safety.UNCERTAINTY_SOURCES`, "" where none), ``conformance_before``
    (on the deviation as measured) and ``conformance_after`` (on the predicted value, with the same
    U) to each row; a position zone is judged on its radial distance against its radius.
    """
    if not rows:
        return rows
    u_all, sources = dimension_uncertainty(model, part)
    dims = {d.id: (i, d) for i, d in enumerate(model.dimensions)}
    at = np.array([dims[r["id"]][0] for r in rows])
    lower = np.array([dims[r["id"]][1].lower for r in rows], dtype=np.float64)
    upper = np.array([dims[r["id"]][1].upper for r in rows], dtype=np.float64)
    zone = np.array([dims[r["id"]][1].zone for r in rows], dtype=bool)
    values = np.array([[r["deviation"], r["predicted"]] for r in rows], dtype=np.float64).T
    codes = conformance_codes(values, lower, upper, u_all[at], zone)
    before, after = conformance_names(codes[0]), conformance_names(codes[1])
    return [
        row
        | {
            "uncertainty": float(u_all[i]),
            "uncertainty_source": sources[i],
            "conformance_before": b,
            "conformance_after": a,
        }
        for row, i, b, a in zip(rows, at.tolist(), before, after, strict=True)
    ]
