"""Proof on later parts: walk forward, and the forecast of the next cycle."""

from __future__ import annotations

import numpy as np
import pytest

from setupfix.diagnose import Diagnoser, EffectSpec, Layout, fit_model, walk_forward
from setupfix.diagnose.walk import margins_of, next_cycle

from diagnose.helpers import guide_pins, one_effect, simulate


@pytest.mark.parametrize("kind", ["drift", "wear"])
def test_augmented_beats_declared_ewma_and_none_with_a_hidden_effect(kind):
    layout = Layout.from_model(guide_pins(positions=False))
    sim = simulate(layout, [one_effect(layout, kind)], seed=7)
    b = walk_forward(layout, sim.series).budgets
    assert b["augmented"].mean_budget > max(b["declared"].mean_budget, b["ewma"].mean_budget, b["none"].mean_budget)
    assert b["augmented"].rms < min(b["declared"].rms, b["ewma"].rms, b["none"].rms)


def test_augmented_is_the_declared_model_without_a_hidden_effect():
    layout = Layout.from_model(guide_pins(positions=False))
    sim = simulate(layout, seed=8)
    b = walk_forward(layout, sim.series).budgets
    np.testing.assert_allclose(b["augmented"].budget, b["declared"].budget)
    assert b["declared"].mean_budget > b["none"].mean_budget


def test_counterfactual_of_keeping_the_registers_is_the_measured_series():
    """Without corrections logged, 'none' keeps the registers: its deviations are the measured ones."""
    layout = Layout.from_model(guide_pins(positions=False))
    sim = simulate(layout, seed=9, correct_every=0, n_cycles=12)
    wf = walk_forward(layout, sim.series, min_train=4)
    dev = sim.series.deviation[4:]
    m = margins_of(dev, layout.lower, layout.upper).min(axis=1)
    np.testing.assert_allclose(wf.budgets["none"].budget, m)


def test_forecast_extrapolates_drift_one_cycle_ahead_with_pending_corrections():
    layout = Layout.from_model(guide_pins(positions=False))
    sim = simulate(layout, [one_effect(layout, "drift")], seed=3, noise=0.0, decimals=12)
    s = sim.series
    fit = fit_model(layout, s, (EffectSpec("drift"),))
    dev, nxt = next_cycle(layout, s, fit)
    step = nxt.time[0] - s.time[-1]
    assert step == pytest.approx(20 / 60)
    # truth: (setup + registers now) @ C + drift at the next time
    c_t = layout.composite[layout.tools].sum(axis=0)
    truth = (sim.setup_error + s.applied[-1] + s.pending) @ layout.composite + 0.002 * nxt.time[0] * c_t
    np.testing.assert_allclose(dev, truth, atol=1e-9)


def test_series_of_one_is_diagnosed_without_walking():
    layout = Layout.from_model(guide_pins())
    sim = simulate(layout, seed=2, n_cycles=1)
    d = Diagnoser().run(layout, sim.series)
    assert d.walk is None and any("too few to walk" in n for n in d.notes)
    assert np.isfinite(d.forecast).all()
