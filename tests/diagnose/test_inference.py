"""Evidence counted per cycle: the cluster-robust test against the sandwich it stands for, its level
under shared per-part noise, and the simulator's shared per-part variation."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest
import scipy.stats

from bench.diagnosis import NOISE, guide_pins, simulate
from setupfix.diagnose import Layout
from setupfix.diagnose.inference import cluster_test, cycle_sums, dimension_pvalue, lack_of_fit


def _design(
    rng: np.random.Generator, n_cycles: int = 12, n_dims: int = 5
) -> tuple[npt.NDArray[np.int_], npt.NDArray[np.int_], npt.NDArray[np.float64]]:
    cycle = np.repeat(np.arange(n_cycles), n_dims)
    dim = np.tile(np.arange(n_dims), n_cycles)
    base = np.eye(n_dims)[dim]  # one constant per dimension
    return cycle, dim, base


def test_cluster_test_is_the_sandwich_wald_test_of_the_full_regression() -> None:
    rng = np.random.default_rng(0)
    cycle, dim, base = _design(rng)
    K = 12
    z = rng.normal(size=cycle.size) + rng.normal(size=K)[cycle]  # shared per-cycle part
    col = rng.normal(size=K)[cycle] * (1 + dim)  # a time-dependent candidate
    Q = np.linalg.qr(base)[0]
    r = z - Q @ (Q.T @ z)
    zt = col - Q @ (Q.T @ col)
    stat, p = cluster_test(zt[:, None], r, cycle, K)
    # brute force: OLS with every column, CR1 sandwich (XᵀX)⁻¹ Σ_k X_kᵀ e_k e_kᵀ X_k (XᵀX)⁻¹ · K/(K − 1)
    X = np.column_stack([base, col])
    beta, *_ = np.linalg.lstsq(X, z, rcond=None)
    e = z - X @ beta
    bread = np.linalg.inv(X.T @ X)
    meat = sum(np.outer(X[cycle == k].T @ e[cycle == k], X[cycle == k].T @ e[cycle == k]) for k in range(K))
    V = bread @ meat @ bread * K / (K - 1)
    assert stat[0] == np.float64(stat[0])
    np.testing.assert_allclose(stat[0], beta[-1] ** 2 / V[-1, -1], rtol=1e-10)
    w = np.array([np.sum(zt[cycle == k] ** 2) for k in range(K)])
    nu = min(w.sum() ** 2 / (w @ w) - 1, K - 1)
    np.testing.assert_allclose(p[0], scipy.stats.f.sf(stat[0], 1, nu), rtol=1e-10)


def test_cycle_sums_do_not_depend_on_the_order_of_the_cells() -> None:
    rng = np.random.default_rng(1)
    cycle = np.sort(rng.integers(0, 7, 40))
    v = rng.normal(size=(40, 3))
    perm = rng.permutation(40)
    np.testing.assert_allclose(cycle_sums(v, cycle, 9), cycle_sums(v[perm], cycle[perm], 9))
    assert np.all(cycle_sums(v, cycle, 9)[7:] == 0)


def test_level_holds_when_every_cell_of_a_cycle_shares_noise() -> None:
    """Shared noise 2× the cell noise, a time-dependent column: the cell-level F-test rejects far more
    often than α, the per-cycle test at most α (binomial bound over 400 draws)."""
    rng = np.random.default_rng(2)
    K, d = 30, 8
    cycle, _, base = _design(rng, K, d)
    Q = np.linalg.qr(base)[0]
    t = np.arange(K, dtype=float)[cycle]
    zt = t - Q @ (Q.T @ t)
    alpha, n = 0.05, 400
    per_cycle = cells = 0
    for _ in range(n):
        z = rng.normal(size=cycle.size) + 2.0 * rng.normal(size=K)[cycle]
        r = z - Q @ (Q.T @ z)
        per_cycle += cluster_test(zt[:, None], r, cycle, K)[1][0] < alpha
        gain = (zt @ r) ** 2 / (zt @ zt)
        df = cycle.size - d - 1
        cells += scipy.stats.f.sf(gain / ((r @ r - gain) / df), 1, df) < alpha
    bound = scipy.stats.binom.isf(0.001, n, alpha)
    assert per_cycle <= bound < cells


def test_dimension_test_uses_that_dimensions_own_variance() -> None:
    rng = np.random.default_rng(3)
    r_q = rng.normal(size=30)
    u = rng.normal(size=30)
    gain = float((u @ r_q) ** 2 / (u @ u))
    df = 30 - 1 - 1
    want = scipy.stats.f.sf(gain / ((r_q @ r_q - gain) / df), 1, df)
    assert dimension_pvalue(gain, r_q, 1) == np.float64(want)


def test_lack_of_fit_sees_constant_offsets_not_noise() -> None:
    rng = np.random.default_rng(4)
    K, d = 20, 6
    cycle, dim, _ = _design(rng, K, d)
    noise = rng.normal(size=cycle.size) * 0.002
    assert lack_of_fit(dim, noise - noise.mean(), cycle.size, 1, 0.01) is None
    offsets = np.array([0.0, 0.01, -0.01, 0.005, 0.0, -0.005])[dim]
    out = lack_of_fit(dim, noise + offsets, cycle.size, 1, 0.01)
    assert out is not None and out[1] == d - 1


def test_simulated_parts_vary_as_a_whole() -> None:
    """part_noise: every tool off by its own offset each cycle, so the cells a tool cuts move together;
    without it the seed's series is unchanged."""
    layout = Layout.from_model(guide_pins())
    plain = simulate(layout, seed=5, correct_every=0).series.deviation
    shared = simulate(layout, seed=5, correct_every=0, part_noise=3 * NOISE).series.deviation
    assert np.array_equal(plain, simulate(layout, seed=5, correct_every=0, part_noise=0.0).series.deviation)
    extra = shared - plain
    C_t = layout.composite[layout.tools]
    # the extra part lies in the span of the tool rows of C, cycle by cycle
    coef = np.linalg.lstsq(C_t.T, extra.T, rcond=None)[0]
    assert np.abs(extra - coef.T @ C_t).max() < 1e-3
    assert 2 * NOISE < np.std(coef) < 4 * NOISE


def test_cluster_wald_is_the_sandwich_wald_test_of_a_block_and_reduces_to_the_one_column_test() -> None:
    from setupfix.diagnose.inference import cluster_wald, orth

    rng = np.random.default_rng(3)
    cycle, dim, base = _design(rng, n_cycles=30)
    K = 30
    z = rng.normal(size=cycle.size) + rng.normal(size=K)[cycle]
    x = rng.normal(size=K)
    block = np.column_stack([x[cycle] * (dim == j) for j in range(3)])  # one coefficient per "register"
    Q = orth(base)
    r = z - Q @ (Q.T @ z)
    Zt = block - Q @ (Q.T @ block)
    f, p, q = cluster_wald(Zt, r, cycle, K)
    # brute force: OLS with every column, CR1 sandwich, Wald on the block's three coefficients
    X = np.column_stack([base, block])
    beta, *_ = np.linalg.lstsq(X, z, rcond=None)
    e = z - X @ beta
    bread = np.linalg.pinv(X.T @ X)
    meat = sum(np.outer(X[cycle == k].T @ e[cycle == k], X[cycle == k].T @ e[cycle == k]) for k in range(K))
    V = (bread @ meat @ bread * K / (K - 1))[-3:, -3:]
    W = beta[-3:] @ np.linalg.solve(V, beta[-3:])
    assert q == 3
    w = np.column_stack([np.bincount(cycle, Zt[:, j] ** 2, K) for j in range(3)])
    nu = min(np.clip(w.sum(0) ** 2 / (w**2).sum(0) - 1, 1, K - 1))
    np.testing.assert_allclose(f, W * (nu - 2) / (nu * 3), rtol=1e-6)
    np.testing.assert_allclose(p, scipy.stats.f.sf(f, 3, nu - 2), rtol=1e-9)
    one_f, one_p, _ = cluster_wald(Zt[:, :1], r, cycle, K)
    stat, pp = cluster_test(Zt[:, :1] / np.linalg.norm(Zt[:, 0]), r, cycle, K)
    np.testing.assert_allclose([one_f, one_p], [stat[0], pp[0]], rtol=1e-8)


@pytest.mark.slow
def test_cluster_wald_holds_its_level_under_shared_per_part_noise() -> None:
    from setupfix.diagnose.inference import cluster_wald, orth

    rng = np.random.default_rng(7)
    K, n_d = 20, 6
    cycle, dim, base = _design(rng, n_cycles=K, n_dims=n_d)
    Q = orth(base)
    x = (np.arange(K) >= 10).astype(float)  # a two-level factor, as the plate's stick-out
    block = np.column_stack([(x[cycle] - x.mean()) * (dim // 2 == j) for j in range(3)])
    Zt = block - Q @ (Q.T @ block)
    ps = []
    for _ in range(400):
        z = rng.normal(size=cycle.size) + 2.0 * rng.normal(size=K)[cycle]  # shared part 2× the cell noise
        ps.append(cluster_wald(Zt, z - Q @ (Q.T @ z), cycle, K)[1])
    rate = np.mean(np.array(ps) < 0.05)
    assert rate <= scipy.stats.binom.ppf(0.999, 400, 0.05) / 400  # at most the nominal 5 % within its noise
