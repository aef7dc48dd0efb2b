"""GM(1,N)/GMC(1,N) against hand-computed series, direct sums and Tien's published example."""

from __future__ import annotations

import math

import numpy as np
import pytest

from setupfix.thermal import grey


def test_ago_iago_background_by_hand() -> None:
    x = np.array([1.0, 2.0, 4.0])
    assert grey.ago(x).tolist() == [1.0, 3.0, 7.0]
    assert grey.iago([1.0, 3.0, 7.0]).tolist() == [1.0, 2.0, 4.0]
    assert grey.background([1.0, 3.0, 7.0]).tolist() == [2.0, 5.0]


def test_gmc_design_by_hand() -> None:
    y = [1.0, 2.0, 3.0]
    X = [[1.0], [1.0], [2.0]]
    B, Y = grey.gmc_design(y, X)
    # y1 = [1, 3, 6] -> z1 = [2, 4.5]; X1 = [1, 2, 4] -> z2 = [1.5, 3]
    np.testing.assert_allclose(B, [[-2.0, 1.5, 1.0], [-4.5, 3.0, 1.0]])
    np.testing.assert_allclose(Y, [2.0, 3.0])
    B, _ = grey.gm1n_design(y, X)
    np.testing.assert_allclose(B, [[-2.0, 2.0], [-4.5, 4.0]])


def test_gmc_response_hand_computed_three_samples() -> None:
    # b1 = ln 2 (decay 1/2), b2 = 1, u = 0, y0 = 1, drivers all 1 -> f = X1 = [1, 2, 3].
    theta = [math.log(2.0), 1.0, 0.0]
    X1 = [[1.0], [2.0], [3.0]]
    trap = grey.gmc_response(theta, 1.0, X1, "trapezoid")
    np.testing.assert_allclose(trap, [1.0, 0.5 + 0.25 + 1.0, 0.25 + 0.125 + 1.0 + 1.5])
    np.testing.assert_allclose(grey.iago(trap), [1.0, 0.75, 1.125])
    r = math.sqrt(0.5)
    tien = grey.gmc_response(theta, 1.0, X1, "tien")
    np.testing.assert_allclose(tien, [1.0, 0.5 + r * 1.5, 0.25 + r * (0.5 * 1.5 + 2.5)])


@pytest.mark.parametrize("form", ["trapezoid", "tien"])
def test_gmc_response_matches_direct_sums(form: grey.ResponseForm) -> None:
    rng = np.random.default_rng(3)
    n = 12
    X1 = grey.ago(rng.normal(1.0, 0.5, (n, 2)))
    theta = np.array([0.37, 0.8, -0.3, 1.2])
    y0 = 0.7
    b1 = theta[0]
    f = X1 @ theta[1:3] + theta[3]
    expect = np.empty(n)
    for k in range(1, n + 1):  # 1-based, written as in the papers
        if form == "trapezoid":  # Abdulshahed 2017 eq. (2)
            s = 0.0 if k == 1 else 0.5 * math.exp(-b1 * (k - 1)) * f[0] + 0.5 * f[k - 1]
            s += sum(math.exp(-b1 * (k - t)) * f[t - 1] for t in range(2, k))
        else:  # Tien 2012
            s = sum(math.exp(-b1 * (k - t + 0.5)) * 0.5 * (f[t - 1] + f[t - 2]) for t in range(2, k + 1))
        expect[k - 1] = y0 * math.exp(-b1 * (k - 1)) + s
    np.testing.assert_allclose(grey.gmc_response(theta, y0, X1, form), expect, rtol=1e-12)
    # a population of parameter sets gives the same rows
    pop = np.vstack([theta, theta * [2, 1, 1, 1]])
    np.testing.assert_allclose(grey.gmc_response(pop, y0, X1, form)[0], expect, rtol=1e-12)


# Tien (2012) hardness -> tensile strength series as reproduced in the research notes §4.2
# (fit on the first 5, forecast the next 5).
TIEN_V = np.array([555, 477, 444, 415, 363, 302, 277, 255, 223, 201], dtype=float)
TIEN_X = np.array([1931, 1724, 1517, 1345, 1207, 1069, 952, 848, 745, 669], dtype=float)


@pytest.mark.parametrize(("form", "fit_mape", "forecast_mape"), [("tien", 1.21, 1.11), ("trapezoid", 1.91, 0.51)])
def test_tien_published_example(form: grey.ResponseForm, fit_mape: float, forecast_mape: float) -> None:
    theta = grey.gmc_least_squares(TIEN_X[:5], TIEN_V[:5, None])
    np.testing.assert_allclose(theta, [0.3652, 0.8299, 2085.9], rtol=2e-4)
    pred = grey.gmc_predict(theta, TIEN_X[0], TIEN_V[:, None], form=form)
    ape = np.abs(pred - TIEN_X) / TIEN_X * 100
    assert ape[1:5].mean() == pytest.approx(fit_mape, abs=0.005)
    assert ape[5:].mean() == pytest.approx(forecast_mape, abs=0.005)


def test_gm1n_response_by_hand() -> None:
    b1 = math.log(2.0)
    theta = [b1, 1.0]
    X1 = np.array([[1.0], [2.0], [3.0]])
    S = X1[:, 0]
    expect = (1.0 - S / b1) * 0.5 ** np.arange(3) + S / b1
    np.testing.assert_allclose(grey.gm1n_response(theta, 1.0, X1), expect)
    assert grey.gm1n_response(theta, 1.0, X1)[0] == pytest.approx(1.0)


@pytest.mark.parametrize("form", ["trapezoid", "tien"])
def test_least_squares_recovers_parameters_of_simulated_series(form: grey.ResponseForm) -> None:
    rng = np.random.default_rng(0)
    X = np.cumsum(rng.normal(0.5, 0.3, (60, 2)), axis=0)
    truth = np.array([0.3, 0.8, -0.4, 1.5])
    y = grey.gmc_predict(truth, 0.0, X, form=form)
    # the grey equation is a discretisation of the response, so LS is close, not exact
    np.testing.assert_allclose(grey.gmc_least_squares(y, X), truth, rtol=0.06)


def test_lag_drivers() -> None:
    X = np.array([[1.0], [2.0], [3.0], [4.0]])
    assert grey.lag_drivers(X, 2)[:, 0].tolist() == [1.0, 1.0, 1.0, 2.0]
    assert grey.lag_drivers(X, 0)[:, 0].tolist() == [1.0, 2.0, 3.0, 4.0]
    with pytest.raises(ValueError):
        grey.lag_drivers(X, -1)


def test_delay_shifts_the_prediction() -> None:
    X = np.zeros((8, 1))
    X[3:] = 1.0
    theta = [0.5, 1.0, 0.0]
    p0 = grey.gmc_predict(theta, 0.0, X, delay=0)
    p2 = grey.gmc_predict(theta, 0.0, X, delay=2)
    np.testing.assert_allclose(p2[2:], p0[:-2], atol=1e-12)
