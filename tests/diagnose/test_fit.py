"""The declared model fitted to a series: setup state on the row space of C, corrections in effect."""

from __future__ import annotations

import numpy as np
import pytest

from bench.diagnosis import guide_pins, simulate
from setupfix.correction.relation import null_space_directions
from setupfix.diagnose import Layout, Series, fit_model
from setupfix.diagnose.fit import Array, row_space_basis


def _series(dev: Array, applied: Array) -> Series:
    n = dev.shape[0]
    return Series(dev, np.arange(n, dtype=float), applied, np.zeros((n, 0)), np.zeros((n, 0)))


def test_noise_free_closed_loop_is_explained_exactly_null_space_included() -> None:
    layout = Layout.from_model(guide_pins())
    C = layout.composite
    rng = np.random.default_rng(3)
    setup = rng.uniform(-0.03, 0.03, C.shape[0])
    applied = np.cumsum(rng.normal(0, 0.01, (12, C.shape[0])), axis=0)
    dev = (setup + applied) @ C  # eqs. 3-4 with the corrections in effect
    fit = fit_model(layout, _series(dev, applied))
    assert np.nanmax(np.abs(fit.residual)) < 1e-12
    np.testing.assert_allclose(fit.offset(), setup @ C, atol=1e-12)
    # the fitted setup is the same whatever null-space direction the true setup carries
    moved = setup + 0.02 * null_space_directions(C)[0]
    fit2 = fit_model(layout, _series((moved + applied) @ C, applied))
    np.testing.assert_allclose(fit2.offset(), fit.offset(), atol=1e-12)


def test_declared_parameters_are_the_rank_of_c() -> None:
    layout = Layout.from_model(guide_pins())
    assert row_space_basis(layout.composite).shape[0] == np.linalg.matrix_rank(layout.composite)


def test_absent_dimensions_are_left_out_not_guessed() -> None:
    layout = Layout.from_model(guide_pins())
    sim = simulate(layout, seed=4, n_cycles=10)
    dev = sim.series.deviation.copy()
    dev[2, 5] = np.nan
    s = sim.series
    fit = fit_model(layout, Series(dev, s.time, s.applied, s.parts, s.temperature))
    assert np.isnan(fit.residual[2, 5])
    assert fit.dof == np.isfinite(dev).sum() - fit.rank
    assert fit.sigma == pytest.approx(0.002, rel=0.25)
