"""Lumped-mass model eq. (4): explicit loop, steady state, and recovery of simulated parameters."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.thermal.lumped import (
    Gearbox,
    fit_lumped,
    heat_inputs,
    lumped_coefficients,
    lumped_equation_error,
    lumped_simulate,
)
from setupfix.thermal.simulator import HeatSource, MachineConfig, simulate, speed_profile


def test_simulate_matches_eq4_loop() -> None:
    rng = np.random.default_rng(0)
    n = 30
    te = 20 + rng.normal(0, 0.1, n)
    speed = rng.choice([0.0, 1000.0, 2000.0], n)
    v1, v2 = 0.05, 0.2
    A, B, C = lumped_coefficients(v1, v2, 0.0, heat_inputs(speed))
    T = [21.0]
    for j in range(1, n):  # (1 + v1) T^j = T^{j-1} + v1 Te^j + v2 n^j
        T.append((T[-1] + v1 * te[j] + v2 * speed[j] / 1000) / (1 + v1))
    np.testing.assert_allclose(lumped_simulate(A, B, C, te, 21.0), T, rtol=1e-12)
    assert float(A + B) == pytest.approx(1.0)


def test_steady_state_rise() -> None:
    n = 4000
    A, B, C = lumped_coefficients(0.01, 0.03, 0.0, heat_inputs(np.full(n, 2000.0)))
    T = lumped_simulate(A, B, C, np.full(n, 20.0), 20.0)
    assert T[-1] == pytest.approx(20.0 + 0.03 * 2.0 / 0.01, rel=1e-6)  # rise = v2 n / v1


def test_gearbox_ratio_steps() -> None:
    box = Gearbox((750.0,), (1102 / 2263, 464 / 3796))
    np.testing.assert_allclose(box.ratio([0, 700, 750, 3000]), [1102 / 2263] * 2 + [464 / 3796] * 2)
    with pytest.raises(ValueError):
        Gearbox((750.0,), (1.0,))


def test_equation_error_exact_on_noise_free_data() -> None:
    speed = speed_profile("variable", 300, rng=np.random.default_rng(3))
    te = np.full(300, 20.0)
    heat = heat_inputs(speed)
    A, B, C = lumped_coefficients(0.004, 0.02, 0.0, heat)
    T = lumped_simulate(A, B, C, te, 20.0)
    np.testing.assert_allclose(lumped_equation_error(T, te, heat), [0.004, 0.02], rtol=1e-6)


def test_ga_recovers_simulated_machine() -> None:
    cfg = MachineConfig(sources=(HeatSource("s", tau_s=1500.0, rise_per_krpm=4.0, error_mm_per_k=0.004),))
    run = simulate(speed_profile("variable", 600, rng=np.random.default_rng(4)), cfg, seed=4)
    fr = run.frame
    params, res = fit_lumped(
        fr["s"].to_numpy(), fr["ambient"].to_numpy(), fr["spindle_speed"].to_numpy(), rng=np.random.default_rng(0)
    )
    v1, v2 = cfg.sources[0].coefficients(cfg.dt_s)
    assert params.v1 == pytest.approx(v1, rel=0.1)
    assert params.v2 / params.v1 == pytest.approx(v2 / v1, rel=0.05)  # steady rise per 1000 rpm
    assert res.fun < 0.3  # F1 (eq. 12) in °C, noise 0.05 + process noise
