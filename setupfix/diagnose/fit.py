"""Fit the declared model to a series, and the model with effects added.

Every measured cell (cycle k, dimension q) is one observation of

    z_kq = y_kq − (u_k · C)_q = b_q + Σ_e β_e · z_e[k, q] + ε_kq

where b = s · C is the unknown setup state seen through the composite matrix.  The
setup state is identified only modulo the null space of C, so b is parametrised
on an orthonormal basis of the row space of C (rank r columns): the declared model
has r parameters however many registers it has.  Effects add columns (one, or two
for a relation: slope on the register's applied change and a free constant on the
dimension, the δ · s_i part).  Ordinary least squares by QR/SVD (numpy).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from setupfix.diagnose.robust import cr2_covariance
from setupfix.diagnose.terms import EffectSpec, Layout, Series, effect_field, field_factors

__all__ = [
    "Observations",
    "Fit",
    "observations",
    "row_space_basis",
    "effect_columns",
    "dense_columns",
    "fit_model",
    "RELATION_T",
]

#: Fewest parts for the cluster-robust (CR2) standard errors; fewer keep σ²(XᵀX)⁻¹.
ROBUST_MIN_CYCLES = 4

#: A relation weight changes the matrix corrections are mapped through only when |δ| > RELATION_T · s.e.
RELATION_T = 3.0

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Observations:
    """The measured cells of a series, flattened.

    Attributes
    ----------
    z : ndarray (N,) [model unit]
        Deviation minus the applied corrections' effect, y − u · C.
    cycle, dim : ndarray of int (N,)
        Cycle and dimension index of each cell.
    base : ndarray (N, r)
        Row-space basis of C evaluated at each cell's dimension.
    """

    z: Array
    cycle: npt.NDArray[np.intp]
    dim: npt.NDArray[np.intp]
    base: Array

    @property
    def n(self) -> int:
        return int(self.z.size)


def row_space_basis(composite: Array, tol: float = 1e-9) -> Array:
    """Orthonormal basis of the row space of C, shape (rank, n_dimensions)."""
    if composite.size == 0:
        return np.zeros((0, composite.shape[1]))
    _, s, vt = np.linalg.svd(composite, full_matrices=False)
    rank = int(np.sum(s > tol * max(1.0, s.max(initial=0.0))))
    out: Array = vt[:rank]
    return out


def observations(layout: Layout, series: Series, basis: Array | None = None) -> Observations:
    """Flatten the measured cells of ``series`` with the declared model's columns."""
    basis = row_space_basis(layout.composite) if basis is None else basis
    z_full = series.deviation - series.applied @ layout.composite
    cycle, dim = np.nonzero(np.isfinite(z_full))
    return Observations(z_full[cycle, dim], cycle.astype(np.intp), dim.astype(np.intp), basis[:, dim].T.copy())


def dense_columns(specs: list[EffectSpec], layout: Layout, series: Series, obs: Observations) -> Array:
    """One column per (non-relation) effect at the observed cells, shape (N, len(specs)): the fields'
    factors (:func:`~setupfix.diagnose.terms.field_factors`) evaluated at each cell's cycle and dimension."""
    if not specs:
        return np.zeros((obs.n, 0))
    pairs = [field_factors(s, layout, series) for s in specs]
    if any(p is None for p in pairs):
        raise ValueError("dense_columns: a relation has two columns (effect_columns)")
    out: Array = np.empty((obs.n, len(specs)), order="F")  # column by column, each contiguous
    for j, p in enumerate(pairs):
        if p is not None:
            np.multiply(p[0][obs.cycle], p[1][obs.dim], out=out[:, j])
    return out


def effect_columns(spec: EffectSpec, layout: Layout, series: Series, obs: Observations) -> Array:
    """Design columns of one effect at the observed cells, shape (N, 1) or (N, 2) for a relation."""
    field = effect_field(spec, layout, series)[obs.cycle, obs.dim]
    if spec.kind == "relation":
        q = layout.dimension_ids.index(str(spec.dimension))
        return np.column_stack([field, (obs.dim == q).astype(float)])
    return field[:, None]


@dataclass(frozen=True)
class Fit:
    """Least-squares fit of the declared model plus ``specs``.

    Attributes
    ----------
    specs : tuple of EffectSpec
    coef : ndarray (p,)
        Base coefficients (r) then each effect's columns in order.
    cov : ndarray (p, p)
        σ² (XᵀX)⁻¹ (pseudo-inverse where X is rank deficient).
    robust_cov : ndarray (p, p) or None
        Cluster-robust CR2 covariance with the part as the cluster
        (:func:`~setupfix.diagnose.robust.cr2_covariance`); None for series of fewer than
        :data:`ROBUST_MIN_CYCLES` parts.  The standard errors :meth:`estimate` gives.
    sigma : float [model unit]
        Residual standard deviation (√(RSS / (N − rank))).
    residual : ndarray (n_cycles, n_dimensions)
        z − fitted, NaN where absent.
    rank, dof : int
    basis : ndarray (r, n_dimensions)
    spans : tuple of slice
        Columns of each effect in ``coef``.
    dimension_ids : tuple of str
    """

    specs: tuple[EffectSpec, ...]
    coef: Array
    cov: Array
    sigma: float
    residual: Array
    rank: int
    dof: int
    basis: Array
    spans: tuple[slice, ...]
    dimension_ids: tuple[str, ...]
    robust_cov: Array | None = None

    @property
    def rss(self) -> float:
        return float(np.nansum(self.residual**2))

    def estimate(self, i: int) -> tuple[float, float]:
        """(estimate, standard error) of effect ``i`` (the slope for a relation).

        The error is the cluster-robust one (CR2, the part as the cluster) when the series has
        :data:`ROBUST_MIN_CYCLES` parts or more: it holds when the parts vary as a whole.
        """
        j = self.spans[i].start
        cov = self.cov if self.robust_cov is None else self.robust_cov
        return float(self.coef[j]), float(np.sqrt(max(cov[j, j], 0.0)))

    def offset(self) -> Array:
        """Fitted setup state seen through C plus every static constant, shape (n_dimensions,)."""
        r = self.basis.shape[0]
        out: Array = self.coef[:r] @ self.basis
        for spec, span in zip(self.specs, self.spans, strict=True):
            if spec.kind == "relation":
                # the free constant (δ · s_i) of a relation sits on its dimension
                out = out.copy()
                out[self._dim(spec)] += self.coef[span.stop - 1]
        return out

    def _dim(self, spec: EffectSpec) -> int:
        return self.dimension_ids.index(str(spec.dimension))

    def predict(self, layout: Layout, series: Series, *, applied: bool = True) -> Array:
        """Predicted z = y − u · C at every cycle of ``series``, shape (n_cycles, n_dimensions).

        With ``applied=False`` the relation slopes are left out (they act through the
        registers; see :meth:`relation_matrix`).
        """
        out = np.broadcast_to(self.offset(), series.deviation.shape).copy()
        for spec, span in zip(self.specs, self.spans, strict=True):
            if spec.kind == "relation" and not applied:
                continue
            out += self.coef[span.start] * effect_field(spec, layout, series)
        return out

    def relation_matrix(self, layout: Layout, skip: Collection[EffectSpec] = ()) -> Array:
        """Composite matrix with the found relation effects added, C + Σ δ e_i e_qᵀ.

        Only weights known to better than a third of themselves (|δ| > 3 s.e.) change the
        matrix the corrections are mapped through: an uncertain weight would amplify noise
        into a correction.  Relations in ``skip`` (those whose register the series cannot
        name: it moved together with others) never do: putting the weight on one register
        of the set would be a guess.
        """
        C = layout.composite.copy()
        for i, spec in enumerate(self.specs):
            est, se = self.estimate(i)
            if spec.kind == "relation" and spec not in skip and abs(est) > RELATION_T * se:
                C[layout.register_ids.index(str(spec.register)), layout.dimension_ids.index(str(spec.dimension))] += est
        return C


def fit_model(
    layout: Layout,
    series: Series,
    specs: tuple[EffectSpec, ...] | list[EffectSpec] = (),
    obs: Observations | None = None,
) -> Fit:
    """Least-squares fit of the declared model (setup state) plus the effects ``specs``.

    Parameters
    ----------
    layout : Layout
    series : Series
    specs : sequence of EffectSpec
    obs : Observations, optional
        Precomputed :func:`observations` of ``series``.

    Returns
    -------
    Fit
    """
    specs = tuple(specs)
    obs = observations(layout, series) if obs is None else obs
    blocks = [obs.base] + [effect_columns(s, layout, series, obs) for s in specs]
    X = np.hstack(blocks) if blocks else np.zeros((obs.n, 0))
    spans = []
    start = obs.base.shape[1]
    for b in blocks[1:]:
        spans.append(slice(start, start + b.shape[1]))
        start += b.shape[1]
    # one SVD gives the minimum-norm solution, the rank and (XᵀX)⁺ = V S⁻² Vᵀ
    u, s, vt = np.linalg.svd(X, full_matrices=False)
    keep = s > 1e-10 * max(1.0, float(s.max(initial=0.0)))
    rank = int(keep.sum())
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    coef: Array = vt.T @ (inv * (u.T @ obs.z))
    resid = obs.z - X @ coef
    dof = max(obs.n - rank, 0)
    rss = float(resid @ resid)
    sigma = float(np.sqrt(rss / dof)) if dof > 0 else float("nan")
    cov: Array = (sigma**2 if dof > 0 else np.nan) * (vt.T * inv**2) @ vt
    field = np.full(series.deviation.shape, np.nan)
    field[obs.cycle, obs.dim] = resid
    robust = None
    if np.unique(obs.cycle).size >= ROBUST_MIN_CYCLES and specs:
        robust = cr2_covariance(u[:, keep], inv[keep], vt[keep], resid, obs.cycle)
    return Fit(
        specs,
        coef,
        cov,
        sigma,
        field,
        int(rank),
        dof,
        row_space_basis(layout.composite),
        tuple(spans),
        layout.dimension_ids,
        robust,
    )
