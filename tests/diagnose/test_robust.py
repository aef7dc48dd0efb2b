"""Printed errors that hold under shared per-part noise: CR2 with the part as the cluster."""

from __future__ import annotations

import numpy as np
import pytest

from bench.diagnosis import NOISE, guide_pins, one_effect, simulate
from setupfix.diagnose import Diagnoser, Layout, fit_model
from setupfix.diagnose.robust import cr2_covariance


def _brute_cr2(X: np.ndarray, e: np.ndarray, cluster: np.ndarray) -> np.ndarray:
    """V_CR2 from its definition with explicit matrices: pinv(XᵀX), the hat matrix and (I − H_kk)^(−½)."""
    B = np.linalg.pinv(X.T @ X)
    H = X @ B @ X.T
    meat = np.zeros((X.shape[1], X.shape[1]))
    for k in np.unique(cluster):
        rows = np.flatnonzero(cluster == k)
        w, v = np.linalg.eigh(np.eye(rows.size) - H[np.ix_(rows, rows)])
        A = v @ np.diag(w**-0.5) @ v.T
        g = X[rows].T @ A @ e[rows]
        meat += np.outer(g, g)
    out: np.ndarray = B @ meat @ B
    return out


def test_cr2_matches_its_definition_also_rank_deficient() -> None:
    rng = np.random.default_rng(0)
    cluster = np.repeat(np.arange(9), 5)
    X = rng.normal(size=(45, 4))
    X = np.column_stack([X, X[:, 0] + X[:, 1]])  # rank 4 of 5 columns
    y = rng.normal(size=45) + np.repeat(rng.normal(size=9), 5)
    u, s, vt = np.linalg.svd(X, full_matrices=False)
    keep = s > 1e-10 * s.max()
    coef = vt[keep].T @ ((u[:, keep].T @ y) / s[keep])
    e = y - X @ coef
    got = cr2_covariance(u[:, keep], 1.0 / s[keep], vt[keep], e, cluster)
    np.testing.assert_allclose(got, _brute_cr2(X, e, cluster), rtol=1e-8, atol=1e-12)


def test_one_cell_per_cluster_is_hc2() -> None:
    """Clusters of one cell: CR2 is HC2, Σ x_i x_iᵀ e_i² / (1 − h_ii) in the sandwich (MacKinnon & White 1985)."""
    rng = np.random.default_rng(1)
    X = np.column_stack([np.ones(30), rng.normal(size=30)])
    y = X @ [1.0, 2.0] + rng.normal(size=30) * (1 + np.abs(X[:, 1]))
    u, s, vt = np.linalg.svd(X, full_matrices=False)
    e = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
    B = np.linalg.inv(X.T @ X)
    h = np.einsum("ij,jk,ik->i", X, B, X)
    hc2 = B @ (X.T * (e**2 / (1 - h))) @ X @ B
    np.testing.assert_allclose(cr2_covariance(u, 1.0 / s, vt, e, np.arange(30)), hc2, rtol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["drift", "wear", "thermal"])
def test_printed_error_is_calibrated_under_shared_per_part_noise(kind: str) -> None:
    """24 seeds, shared per-part noise 2× the cell noise: (estimate − truth)/± has an RMS in [0.7, 1.4]
    (the plain σ²(XᵀX)⁻¹ error gives about 3)."""
    layout = Layout.from_model(guide_pins(positions=False))
    z = []
    for seed in range(24):
        hidden = one_effect(layout, kind)
        sim = simulate(layout, [hidden], seed=seed, part_noise=2 * NOISE)
        est, se = fit_model(layout, sim.series, (hidden.spec,)).estimate(0)
        z.append((est - hidden.magnitude) / se)
    assert 0.7 <= float(np.sqrt(np.mean(np.square(z)))) <= 1.4


@pytest.mark.slow
def test_the_diagnosis_prints_the_robust_error() -> None:
    layout = Layout.from_model(guide_pins(positions=False))
    hidden = one_effect(layout, "wear")
    sim = simulate(layout, [hidden], seed=3, part_noise=2 * NOISE)
    d = Diagnoser(walk=False).run(layout, sim.series)
    (e,) = [e for e in d.effects if e.spec == hidden.spec]
    i = d.after.specs.index(hidden.spec)
    j = d.after.spans[i].start
    assert d.after.robust_cov is not None
    assert e.stderr == pytest.approx(np.sqrt(d.after.robust_cov[j, j]))
    assert e.stderr > 1.5 * np.sqrt(d.after.cov[j, j])  # the plain error is too small under shared noise
