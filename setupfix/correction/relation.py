"""Relation matrices of the four-level graph M → W → F → D plus T → F.

Stryczek (2014) writes the influence of setup data on features and dimensions as
weighted relation matrices R_MW, R_WF, R_TF, R_FD (section "The proposed
compensation system") and predicts the shifts of features and dimensions by

    F = (M · R_MW + W) · R_WF + T · R_TF        (eq. 3)
    D = F · R_FD                                 (eq. 4)

with row vectors M, W, T of register changes.  For the decision vector
x = [W_1 … W_|W|, T_1 … T_|T|] both equations collapse into one composite matrix
C = [R_WF · R_FD ; R_TF · R_FD] of shape (|W| + |T|, |D|), so that D = x · C.

A multi-axis model (``../shared/spec/process-model.md``, *Multi-axis models*) has one
register per component (``W1.X`` … ``W1.C``, ``T5``, ``T5.R``) and vector feature shifts:

    p_f = Σ_W A_fW t_W + Σ_W c_fW θ_W (π/180) (s × x_f) + Σ_T w_fT h_T s
    d_q = Σ_f w_qf (n_q · p_f + Σ_T ρ_fT r_T)         (a size keeps only the ρ terms)

still linear in the components, so C exists as well (:func:`feature_shifts`,
:func:`projected_composite`); a circular position zone is not linear (its margin is
R − ‖δ + d‖): its column of C is zero and its two component columns (along its plane
axes) are :attr:`RelationMatrices.zones`.  Everything here is a pure function on arrays.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import numpy.typing as npt
import scipy.linalg

from setupfix.model import ProcessModel

__all__ = [
    "RelationMatrices",
    "relation_matrices",
    "composite_matrix",
    "predict_features",
    "predict_dimensions",
    "null_space_directions",
    "feature_shifts",
    "projected_composite",
]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class RelationMatrices:
    """The paper's relation matrices with their row and column labels.

    Attributes
    ----------
    R_MW : ndarray of shape (|M|, |W|)
    R_WF : ndarray of shape (|W|, |F|)
    R_TF : ndarray of shape (|T|, |F|)
    R_FD : ndarray of shape (|F|, |D|)
    machines, wks, tools, features, dimensions : list of str
        IDs labelling the rows and columns.
    multi : ndarray of shape (|W| + |T|, |D|) or None
        A multi-axis model's composite (:func:`projected_composite`; R_WF and R_TF then hold
        each component's weight on each feature, R_FD the w_qf, and C is not their product).
    zones : ndarray of shape (|W| + |T|, |D|, 2) or None
        Per unit change of each register, the change of a position zone's two components (along
        its plane axes, :func:`projected_composite`); zeros for other dimensions.  None without zones.
    """

    R_MW: Array
    R_WF: Array
    R_TF: Array
    R_FD: Array
    machines: list[str]
    wks: list[str]
    tools: list[str]
    features: list[str]
    dimensions: list[str]
    multi: Array | None = field(default=None)
    zones: Array | None = field(default=None)

    @cached_property
    def composite(self) -> Array:
        """Composite matrix C, shape (|W| + |T|, |D|): D = [W, T] · C (computed once, read-only)."""
        if self.multi is not None:
            return self.multi
        return _read_only(composite_matrix(self.R_WF, self.R_TF, self.R_FD))

    @property
    def registers(self) -> list[str]:
        return self.wks + self.tools


def _read_only(array: Array) -> Array:
    array.setflags(write=False)
    return array


#: Matrices of the models used last, by ``id``: a batch or the TUI poses one problem per
#: report on the same model, and rebuilding them cost ~0.1 ms each time.  Each entry
#: holds its model, so the ``id`` cannot be reused while the entry lives; a model is
#: immutable (frozen), so its matrices never go stale.
_RECENT: dict[int, tuple[ProcessModel, RelationMatrices]] = {}
_RECENT_SIZE = 8
_RECENT_LOCK = threading.Lock()


def relation_matrices(model: ProcessModel) -> RelationMatrices:
    """R_MW, R_WF, R_TF and R_FD (paper eqs. 3–4) of a process model (read-only arrays).

    Weights are those of the model file: w_az = +1 when an increase of a
    increases z, −1 when it decreases it, absent (0) otherwise; other real weights
    (for example 2 for a radius register acting on a diameter) pass through.
    The result is kept for the last few models (the same object is returned for
    the same model object).
    """
    hit = _RECENT.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    mats = _relation_matrices(model)
    with _RECENT_LOCK:  # the TUI and threaded callers build concurrently
        while len(_RECENT) >= _RECENT_SIZE:
            _RECENT.pop(next(iter(_RECENT)))
        _RECENT[id(model)] = (model, mats)
    return mats


def _relation_matrices(model: ProcessModel) -> RelationMatrices:
    if model.multi_axis:
        return _multi_axis_matrices(model)
    w_ix = {r.id: i for i, r in enumerate(model.wks)}
    t_ix = {r.id: i for i, r in enumerate(model.tools)}
    f_ix = {f.id: i for i, f in enumerate(model.features)}
    r_mw = np.zeros((len(model.machines), len(model.wks)))
    for m, point in enumerate(model.machines):
        for wid, weight in point.wks.items():
            r_mw[m, w_ix[wid]] = weight
    r_wf = np.zeros((len(model.wks), len(model.features)))
    r_tf = np.zeros((len(model.tools), len(model.features)))
    for f, feat in enumerate(model.features):
        for wid, weight in feat.wks.items():
            r_wf[w_ix[wid], f] = weight
        for tid, weight in feat.tools.items():
            r_tf[t_ix[tid], f] = weight
    r_fd = np.zeros((len(model.features), len(model.dimensions)))
    for d, dim in enumerate(model.dimensions):
        for fid, weight in dim.features.items():
            r_fd[f_ix[fid], d] = weight
    return RelationMatrices(
        R_MW=_read_only(r_mw),
        R_WF=_read_only(r_wf),
        R_TF=_read_only(r_tf),
        R_FD=_read_only(r_fd),
        machines=[m.id for m in model.machines],
        wks=[w.id for w in model.wks],
        tools=[t.id for t in model.tools],
        features=[f.id for f in model.features],
        dimensions=[d.id for d in model.dimensions],
    )


def composite_matrix(r_wf: Array, r_tf: Array, r_fd: Array) -> Array:
    """Composite register → dimension matrix C = [R_WF · R_FD ; R_TF · R_FD].

    Parameters
    ----------
    r_wf : ndarray of shape (|W|, |F|)
    r_tf : ndarray of shape (|T|, |F|)
    r_fd : ndarray of shape (|F|, |D|)

    Returns
    -------
    ndarray of shape (|W| + |T|, |D|)
        Row i is the change of every dimension per unit change of register i
        (eqs. 3–4 with M = 0).

    Notes
    -----
    R_FD has a few features per dimension, so the product runs over its non-zero
    entries: O(nnz · (|W| + |T|)) instead of O(|F| · |D| · (|W| + |T|)) (a model of
    10,000 dimensions took seconds and gigabytes as a dense product).
    """
    rows = np.vstack([r_wf, r_tf])
    out = np.zeros((rows.shape[0], r_fd.shape[1]))
    f, d = np.nonzero(r_fd)
    np.add.at(out.T, d, (rows[:, f] * r_fd[f, d]).T)
    return out


def predict_features(
    w: Array, t: Array, r_wf: Array, r_tf: Array, m: Array | None = None, r_mw: Array | None = None
) -> Array:
    """Feature shifts F = (M · R_MW + W) · R_WF + T · R_TF (eq. 3).

    Parameters
    ----------
    w : ndarray of shape (..., |W|) [model unit]
    t : ndarray of shape (..., |T|) [model unit]
    m : ndarray of shape (..., |M|), optional
        Machine point shifts (level 0, usually omitted as the paper says).

    Returns
    -------
    ndarray of shape (..., |F|) [model unit]
    """
    wks = np.asarray(w, dtype=float)
    if m is not None and r_mw is not None and r_mw.size:
        wks = np.asarray(m, dtype=float) @ r_mw + wks
    return wks @ r_wf + np.asarray(t, dtype=float) @ r_tf


def predict_dimensions(x: Array, composite: Array) -> Array:
    """Dimension changes D = x · C for corrections x (eqs. 3–4).

    Parameters
    ----------
    x : ndarray of shape (..., n_registers) [model unit]
        Register corrections, WKS first then tools, or a population of them.
    composite : ndarray of shape (n_registers, n_dimensions)

    Returns
    -------
    ndarray of shape (..., n_dimensions) [model unit]
    """
    return np.asarray(x, dtype=float) @ composite


def null_space_directions(composite: Array, tol: float = 1e-9) -> Array:
    """Corrections that move no dimension: a readable basis of {x : x · C = 0}.

    The orthonormal basis from the SVD is brought to reduced row echelon form,
    each row scaled to a largest absolute entry of 1 and signed so that its last
    non-zero entry (a tool, where there is one) is positive: a direction such as
    "every tool +a with every WKS −a" reads as entries of ±1.

    Parameters
    ----------
    composite : ndarray of shape (n_registers, n_dimensions)

    Returns
    -------
    ndarray of shape (k, n_registers)
        k = n_registers − rank(C) directions (k may be 0).
    """
    a: Array = composite.T  # (|D|, n); its null space is that of its triangular factor (same singular values),
    if a.shape[0] > a.shape[1]:  # whose SVD is n × n: no |D| × |D| factor for a model of many dimensions
        a = np.asarray(np.linalg.qr(a, mode="r"))
    basis = scipy.linalg.null_space(a, rcond=tol)  # (n, k)
    if basis.shape[1] == 0:
        return np.zeros((0, composite.shape[0]))
    rows = basis.T.copy()
    k, n = rows.shape
    lead = 0
    for r in range(k):  # Gauss-Jordan on k ≤ n rows: tiny, no library needed
        while lead < n and np.all(np.abs(rows[r:, lead]) < tol):
            lead += 1
        if lead == n:
            break
        pivot = r + int(np.argmax(np.abs(rows[r:, lead])))
        rows[[r, pivot]] = rows[[pivot, r]]
        rows[r] /= rows[r, lead]
        for other in range(k):
            if other != r:
                rows[other] -= rows[other, lead] * rows[r]
        lead += 1
    for r in range(k):
        rows[r] /= np.abs(rows[r]).max()
        nonzero = np.flatnonzero(np.abs(rows[r]) > tol)
        if rows[r, nonzero[-1]] < 0:  # tools come last: read "tools +a, WKS −a"
            rows[r] = -rows[r]
    rows = np.asarray(np.round(rows, 9) + 0.0, dtype=np.float64)
    rows[np.abs(rows) < tol] = 0.0
    return rows


def feature_shifts(
    translation: Array, axis_unit: Array, rotation: Array, positions: Array, length: Array, spindle: Array
) -> Array:
    """Displacement of every feature per unit change of every register component.

    p_f = Σ_W A_fW t_W + Σ_W c_fW θ_W (π/180) (s × x_f) + Σ_T w_fT h_T s (spec, *Multi-axis
    models*), one row per component: a translation row has its weights in ``translation`` and its
    axis in ``axis_unit``, a rotation row its weights in ``rotation``, a tool length row in ``length``.

    Parameters
    ----------
    translation : ndarray of shape (R, F)
        A_fW[a] for the translation component a of each row (0 elsewhere) [1].
    axis_unit : ndarray of shape (R, 3)
        Unit vector of each translation row's axis (any vector for the other rows) [1].
    rotation : ndarray of shape (R, F)
        c_fW of each rotation row (θ in degrees) [1].
    positions : ndarray of shape (F, 3)
        Nominal feature positions x_f in the WKS frame [unit]; NaN where unknown (only allowed
        where ``rotation`` is 0: the loader refuses a rotated feature without a position).
    length : ndarray of shape (R, F)
        w_fT of each tool length row [1].
    spindle : ndarray of shape (3,)
        Unit vector s of the spindle axis.

    Returns
    -------
    ndarray of shape (R, F, 3)
        Feature displacement per unit of each component [unit per unit, unit per degree].
    """
    lever = np.cross(spindle, np.nan_to_num(positions)) * (np.pi / 180.0)  # (F, 3): s × x_f per degree
    return (
        translation[:, :, None] * axis_unit[:, None, :]
        + rotation[:, :, None] * lever[None, :, :]
        + length[:, :, None] * spindle[None, None, :]
    )


def projected_composite(shifts: Array, radius: Array, r_fd: Array, directions: Array, size: Array) -> Array:
    """Dimension changes per unit of every component: d_q = Σ_f w_qf (n_q · p_f + Σ_T ρ_fT r_T).

    Parameters
    ----------
    shifts : ndarray of shape (R, F, 3)
        :func:`feature_shifts`.
    radius : ndarray of shape (R, F)
        ρ_fT of each tool radius row [1].
    r_fd : ndarray of shape (F, Q)
        w_qf, the features entering each dimension (or zone component).
    directions : ndarray of shape (Q, 3)
        Measuring direction n_q of each column (unit vectors).
    size : bool ndarray of shape (Q,)
        A size keeps only the radius terms.

    Returns
    -------
    ndarray of shape (R, Q) [unit per unit or per degree]
    """
    moved = np.einsum("rfk,fq->rqk", shifts, r_fd)  # Σ_f w_qf p_f, (R, Q, 3)
    along = np.einsum("rqk,qk->rq", moved, directions)
    out: Array = np.where(size[None, :], 0.0, along) + radius @ r_fd
    return out


def _multi_axis_matrices(model: ProcessModel) -> RelationMatrices:
    """The relation of a multi-axis model (module docstring): per-component weights and the composite."""
    regs = model.registers
    f_ix = {f.id: i for i, f in enumerate(model.features)}
    n_r, n_f = len(regs), len(model.features)
    translation, rotation, length, radius = (np.zeros((n_r, n_f)) for _ in range(4))
    axis_unit = np.zeros((n_r, 3))
    for r, reg in enumerate(regs):
        for f, feat in enumerate(model.features):
            if reg.kind == "wks":
                weight = feat.components.get(reg.base, {}).get((reg.component or "").lower(), 0.0)
                (rotation if reg.component == "C" else translation)[r, f] = weight
            elif reg.component == "R":
                radius[r, f] = feat.radius.get(reg.base, 0.0)
            else:
                length[r, f] = feat.tools.get(reg.base, 0.0)
        if reg.component in _AXES:
            axis_unit[r, _AXES.index(reg.component)] = 1.0
    positions = np.array(
        [f.position if f.position is not None else (np.nan,) * 3 for f in model.features], dtype=float
    ).reshape(n_f, 3)
    spindle = np.eye(3)[_AXES.index(model.spindle)]
    shifts = feature_shifts(translation, axis_unit, rotation, positions, length, spindle)
    dims = model.dimensions
    r_fd = np.zeros((n_f, len(dims)))
    for d, dim in enumerate(dims):
        for fid, weight in dim.features.items():
            r_fd[f_ix[fid], d] = weight
    directions = np.array(
        [dim.direction if dim.direction is not None else (0.0, 0.0, 0.0) for dim in dims], dtype=float
    ).reshape(len(dims), 3)
    size = np.array([dim.kind == "size" for dim in dims], dtype=bool)
    composite = projected_composite(shifts, radius, r_fd, directions, size)
    zones = None
    is_zone = np.array([dim.zone for dim in dims], dtype=bool)
    if is_zone.any():
        composite[:, is_zone] = 0.0
        zones = np.zeros((n_r, len(dims), 2))
        for k in range(2):
            plane = np.array([np.eye(3)[_AXES.index(dim.plane[k])] if dim.zone else np.zeros(3) for dim in dims])
            zones[:, :, k] = np.where(
                is_zone[None, :], projected_composite(shifts, radius, r_fd, plane, np.zeros(len(dims), bool)), 0.0
            )
        zones = _read_only(zones)
    return RelationMatrices(
        R_MW=_read_only(np.zeros((0, len(model.wks)))),
        R_WF=_read_only(translation[: len(model.wks)] + rotation[: len(model.wks)]),
        R_TF=_read_only(length[len(model.wks) :] + radius[len(model.wks) :]),
        R_FD=_read_only(r_fd),
        machines=[],
        wks=[w.id for w in model.wks],
        tools=[t.id for t in model.tools],
        features=[f.id for f in model.features],
        dimensions=[d.id for d in dims],
        multi=_read_only(composite),
        zones=zones,
    )


_AXES = ("X", "Y", "Z")
