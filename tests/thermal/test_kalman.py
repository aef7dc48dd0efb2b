"""Scalar Kalman filter: closed-form steady state, scale invariance, failure mode, streaming."""

from __future__ import annotations

import math

import numpy as np
import pytest

from setupfix.thermal import kalman
from setupfix.thermal.kalman import Array
from setupfix.thermal.lumped import lumped_simulate


def test_golden_ratio_steady_state() -> None:
    # A = 1, N = R = 1: P² - P - 1 = 0 -> P = φ, K = φ/(φ+1) = 1/φ.
    phi = (1 + math.sqrt(5)) / 2
    P, K = kalman.steady_state(1.0, 1.0, 1.0)
    assert float(P) == pytest.approx(phi)
    assert float(K) == pytest.approx(1 / phi)


@pytest.mark.slow
@pytest.mark.parametrize(("A", "N", "R"), [(0.99, 0.01, 1.0), (0.5, 2.0, 0.3), (0.999, 1e-5, 0.04)])
def test_iterated_filter_reaches_closed_form(A: float, N: float, R: float) -> None:
    x: float | Array = 0.0
    P: float | Array = 10.0
    for _ in range(20000):
        x, P_prior = kalman.predict(x, P, A, 1 - A, 20.0, 0.0, N)
        x, P, K = kalman.update(x, P_prior, 20.0, R)
    P_inf, K_inf = kalman.steady_state(A, N, R)
    assert float(P_prior) == pytest.approx(float(P_inf), rel=1e-9)
    assert float(K) == pytest.approx(float(K_inf), rel=1e-9)
    # and the closed form is a fixed point of eqs. (6)-(9)
    assert float(A * A * (P_inf - K_inf * P_inf) + N) == pytest.approx(float(P_inf), rel=1e-12)


def test_estimates_depend_only_on_the_ratio() -> None:
    rng = np.random.default_rng(0)
    z = 20 + rng.normal(0, 0.5, 50)
    out = []
    for scale in (1.0, 7.5):
        x = z[0]
        P: float | Array = 1.0 * scale
        xs = []
        for zj in z[1:]:
            x, P = kalman.predict(x, P, 0.95, 0.05, 20.0, 0.1, 0.01 * scale)
            x, P, _ = kalman.update(x, P, zj, 1.0 * scale)
            xs.append(float(x))
        out.append(xs)
    np.testing.assert_allclose(out[0], out[1], rtol=1e-12)


def _setup(n: int = 200) -> tuple[Array, Array, Array, Array, Array, Array]:
    rng = np.random.default_rng(2)
    te = np.full(n, 20.0)
    A, B = np.array([0.98, 0.99]), np.array([0.02, 0.01])
    C = np.vstack([np.full(n, 0.1), np.full(n, 0.05)])
    truth = np.column_stack([lumped_simulate(A[i], B[i], C[i], te, 20.0) for i in range(2)])
    return te, A, B, C, truth, truth + rng.normal(0, 0.3, truth.shape)


def test_fusion_reduces_noise() -> None:
    te, A, B, C, truth, measured = _setup()
    fused, gain = kalman.fuse(measured, te, A, B, C, q=np.array([1e-3, 1e-3]))
    err_f = np.sqrt(np.mean((fused - truth)[50:] ** 2))
    err_m = np.sqrt(np.mean((measured - truth)[50:] ** 2))
    assert err_f < 0.5 * err_m
    np.testing.assert_allclose(gain[-1], kalman.steady_state(A, 1e-3)[1], rtol=1e-4)


def test_jump_sets_gain_to_zero_and_follows_the_model() -> None:
    te, A, B, C, truth, measured = _setup()
    broken = measured.copy()
    broken[120:, 0] = -200.0  # open PT100
    fused, gain = kalman.fuse(broken, te, A, B, C, q=np.array([1e-2, 1e-2]), jump=5.0)
    assert np.all(gain[120:, 0] == 0) and np.all(gain[120:, 1] > 0)
    # from the failure on, sensor 0 is the open-loop lumped-mass model from its last fused value
    model = lumped_simulate(A[0], B[0], C[0, 119:], te[119:], fused[119, 0])
    np.testing.assert_allclose(fused[119:, 0], model, rtol=1e-12)
    assert abs(fused[-1, 0] - truth[-1, 0]) < 1.0


def test_missing_reading_gets_zero_gain_for_that_sample_only() -> None:
    te, A, B, C, _, measured = _setup()
    gapped = measured.copy()
    gapped[60, 1] = np.nan
    _, gain = kalman.fuse(gapped, te, A, B, C, q=np.array([1e-2, 1e-2]), jump=5.0)
    assert gain[60, 1] == 0 and gain[61, 1] > 0


def test_streaming_matches_batch() -> None:
    te, A, B, C, _, measured = _setup()
    measured[150:, 1] = 90.0
    q = np.array([1e-3, 1e-2])
    fused, _ = kalman.fuse(measured, te, A, B, C, q, jump=5.0)
    f = kalman.FusionFilter(A, B, q, jump=5.0)
    stream = np.array([f.step(measured[j], te[j], C[:, j]) for j in range(len(te))])
    np.testing.assert_allclose(stream, fused, rtol=1e-12)
    assert f.failed.tolist() == [False, True]
    assert f.x_post is not None and np.shape(f.P_prior) == (2,)
