"""The model dimensions of a correction problem: a position zone is one dimension, not its facets.

A problem without zones has one column per dimension (two margin rows, eqs. 5–6).  A circular
position zone enters as the k facet columns of its inscribed polygon
(:attr:`~setupfix.optimize.problem.CorrectionProblem.rows` maps them to the zone,
:mod:`setupfix.correction.zones`); the zone's margin is the least of its facets'.  Leximin orders, and the
triage keeps or gives up, model dimensions: these maps give every row and column its dimension,
each dimension its no-harm floor, and the harm check per dimension.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from setupfix.optimize.problem import CorrectionProblem

__all__ = ["dimension_floor", "dimension_margins", "dimension_of_rows", "harmed_columns", "model_dimensions"]

Array = npt.NDArray[np.float64]


def model_dimensions(problem: CorrectionProblem) -> tuple[tuple[str, ...], npt.NDArray[np.intp]]:
    """The model dimensions (a position zone once) and the index among them of each problem column.

    A zone's facet columns (:attr:`~setupfix.optimize.problem.CorrectionProblem.rows`) all map to
    the zone: its margin is the least of its facets'.  Without zones: ``dimension_ids`` and 0 … m−1.

    Returns
    -------
    ids : tuple of str, length n_dims
    column_dim : ndarray of int, shape (n_dimensions,)
    """
    if problem.rows is None:
        return tuple(problem.dimension_ids), np.arange(len(problem.dimension_ids), dtype=np.intp)
    ids = tuple(dict.fromkeys(problem.rows))
    where = {d: i for i, d in enumerate(ids)}
    return ids, np.array([where[r] for r in problem.rows], dtype=np.intp)


def dimension_margins(problem: CorrectionProblem, x: Array) -> Array:
    """Margin of each model dimension after corrections x [unit], shape (..., n_dims).

    The least of its columns' margins (:meth:`~setupfix.optimize.problem.CorrectionProblem.margins`):
    for a zone its polygon's, what the optimisers hold (within
    :attr:`~setupfix.optimize.problem.CorrectionProblem.polygon` below the circle's).

    x : ndarray of shape (..., n_registers) [problem units]
    """
    ids, column_dim = model_dimensions(problem)
    m = problem.margins(np.asarray(x, dtype=float))
    out = np.full((*m.shape[:-1], len(ids)), np.inf)
    for q in range(len(ids)):
        out[..., q] = m[..., column_dim == q].min(axis=-1)
    return out


def dimension_of_rows(problem: CorrectionProblem) -> npt.NDArray[np.intp]:
    """Index of the model dimension (:func:`model_dimensions`) of each margin row of :func:`margin_rows`, shape (r,).

    Without zones it is the problem column (``problem.dimension_ids``); a zone's facet rows all name the zone.
    """
    _, column_dim = model_dimensions(problem)
    cols = np.concatenate([np.flatnonzero(np.isfinite(problem.upper)), np.flatnonzero(np.isfinite(problem.lower))])
    rows: npt.NDArray[np.intp] = column_dim[cols.astype(np.intp)]
    return rows


def dimension_floor(problem: CorrectionProblem) -> Array:
    """The no-harm floor of each model dimension [unit], shape (n_dims,) (−inf: not held).

    A dimension's floor is its column's :attr:`~setupfix.optimize.problem.CorrectionProblem.held_floor`.
    A zone is held when its circle is measured inside (margin R − ‖δ‖ ≥ 0): every facet then keeps
    at least the least of its floors (−inf: the facet's margin before the correction, below 0 only
    by the polygon's error), so no correction moves the zone further out than it was.
    """
    ids, column_dim = model_dimensions(problem)
    col = problem.held_floor
    out = np.full(len(ids), np.inf)
    circles = problem.circles
    if circles is not None:
        where = {d: i for i, d in enumerate(ids)}
        inside = np.zeros(len(ids), bool)
        inside[[where[z] for z in circles.ids]] = circles.margins(np.zeros(problem.n_registers)) >= 0
        col = np.where(
            np.isfinite(col) | ~inside[column_dim], col, np.minimum(problem.margins(np.zeros(problem.n_registers)), 0.0)
        )
    np.minimum.at(out, column_dim, col)
    return out


def harmed_columns(problem: CorrectionProblem, x: Array) -> npt.NDArray[np.bool_]:
    """Columns of the dimensions a correction harms: measured in tolerance, predicted out, shape (n_dimensions,).

    A dimension with one column: inside its limits before, outside after x [unit].  A position zone
    as a whole (:func:`dimension_floor`): measured inside its circle and some facet of its polygon
    predicted below that floor (those facets are flagged); a zone measured outside its circle cannot
    be harmed, whatever its facets do one by one.
    """
    dev, pred = problem.deviation, problem.predicted(np.asarray(x, dtype=float))
    before = (dev >= problem.lower) & (dev <= problem.upper)
    after = (pred >= problem.lower - 1e-12) & (pred <= problem.upper + 1e-12)
    out: npt.NDArray[np.bool_] = before & ~after
    if problem.circles is None or problem.rows is None:
        return out
    _, column_dim = model_dimensions(problem)
    floor = dimension_floor(problem)[column_dim]
    zone = np.isin(np.array(problem.rows, dtype=object), np.array(problem.circles.ids, dtype=object))
    out[zone] = (np.isfinite(floor) & (problem.margins(np.asarray(x, dtype=float)) < floor - 1e-12))[zone]
    return out
