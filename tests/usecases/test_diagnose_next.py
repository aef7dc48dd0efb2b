"""The diagnosis's next correction: from the model that earned it, through the one ``correct`` use case."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bench.diagnosis import guide_pins, one_effect, simulate
from setupfix.diagnose import Diagnoser, Diagnosis, Layout, Series
from setupfix.diagnose.walk import NextSource, centred_registers, ewma_forecast
from setupfix.usecases.correct import correct_cycle
from setupfix.usecases.diagnosis import forecast_model, recommend_next, series_history
from setupfix.usecases.requests import CorrectRequest, CycleCorrection

MODEL = guide_pins(positions=False)
LAYOUT = Layout.from_model(MODEL)


def _random_walk(seed: int, step: float = 0.004) -> Series:
    sim = simulate(LAYOUT, seed=seed, correct_every=0)
    s = sim.series
    rng = np.random.default_rng(seed)
    wander = np.zeros((s.n_cycles, LAYOUT.n_registers))
    wander[:, 0] = np.cumsum(rng.normal(0, step, size=s.n_cycles))
    return dataclasses.replace(s, deviation=np.round(s.deviation + wander @ LAYOUT.composite, 4))


@pytest.mark.slow
def test_ewma_recommendation_is_the_correct_use_case_on_the_smoothed_series() -> None:
    """EWMA chosen: ``correct`` smooths the last part over the series (its History), and what it poses is the
    engine's own EWMA forecast -- two implementations of one estimate agree."""
    d = Diagnoser().run(LAYOUT, _random_walk(5))
    assert d.next_from.source == "ewma"
    cycle, notes = recommend_next(MODEL, d)
    assert cycle is not None
    assert "ewma" in [e.rule for e in cycle.posed.effects]
    assert d.next_forecast is not None
    measured = np.isfinite(d.next_forecast)
    np.testing.assert_allclose(cycle.posed.problem.deviation, d.next_forecast[measured], atol=1e-9)
    np.testing.assert_allclose(d.next_forecast, ewma_forecast(LAYOUT, d.series, 0.3))
    assert any("did not beat ewma" in str(n) for n in notes)


def test_ewma_recommendation_moves_the_earlier_parts_by_the_corrections_logged() -> None:
    """With corrections during the series and after its last part, the smoothed estimate is at the registers
    the next part has."""
    sim = simulate(LAYOUT, seed=11, correct_every=3)
    s = dataclasses.replace(sim.series, pending=np.where(np.arange(LAYOUT.n_registers) == 2, 0.01, 0.0))
    d = Diagnoser(walk=False).run(LAYOUT, s)
    d = dataclasses.replace(
        d, next_from=NextSource("ewma", ""), next_forecast=ewma_forecast(LAYOUT, s, 0.3), centred=None
    )
    cycle, _ = recommend_next(MODEL, d)
    assert cycle is not None and d.next_forecast is not None
    np.testing.assert_allclose(cycle.posed.problem.deviation, d.next_forecast[np.isfinite(d.next_forecast)], atol=1e-9)


@pytest.mark.slow
def test_augmented_recommendation_when_the_effect_earned_it() -> None:
    d = Diagnoser().run(LAYOUT, simulate(LAYOUT, [one_effect(LAYOUT, "drift")], seed=7).series)
    assert d.next_from.source == "augmented"
    cycle, notes = recommend_next(MODEL, d)
    assert cycle is not None and "ewma" not in [e.rule for e in cycle.posed.effects]
    np.testing.assert_allclose(cycle.posed.problem.deviation, d.forecast, atol=1e-12)
    assert not any("did not beat" in str(n) for n in notes)


@pytest.mark.slow
def test_centre_rule_holds_the_registers_whose_dimensions_sat_at_the_centre() -> None:
    """Uncorrected setup errors (±0.03 mm) and a wandering W1: registers whose dimensions happen to sit within a
    quarter of the half tolerance are held -- without the rule the optimiser moves them."""
    d = Diagnoser().run(LAYOUT, _random_walk(5))
    assert d.centred is not None
    held = [rid for rid, h in zip(LAYOUT.register_ids, d.centred, strict=True) if h]
    assert held, "some registers sit at the centre"
    cycle, notes = recommend_next(MODEL, d)
    assert cycle is not None
    rule = next(r for r in cycle.recommendation.rules if r.rule == "centred")
    assert set(rule.registers) == set(held)
    assert all(cycle.corrections.get(r, 0.0) == 0.0 for r in held)
    assert any("never move what sits at the centre" in str(n) for n in notes)
    # every dimension a held register moves sat within a quarter of its half tolerance on the last two parts
    C = d.next_matrix()
    half = (LAYOUT.upper - LAYOUT.lower) / 2
    centre = (LAYOUT.upper + LAYOUT.lower) / 2
    for r in held:
        q = C[LAYOUT.register_ids.index(r)] != 0
        assert np.all(np.abs(d.series.deviation[-2:, q] - centre[q]) <= 0.25 * half[q] + 1e-12)
    free = _free_cycle(d)
    assert any(abs(free.corrections.get(r, 0.0)) > 0 for r in held), "without the rule they would move"


def _free_cycle(d: Diagnosis) -> CycleCorrection:
    """The same EWMA recommendation without the centre rule."""
    history, part = series_history(MODEL, d)
    model = forecast_model(MODEL)
    model = dataclasses.replace(model, safety=dataclasses.replace(model.safety, ewma=0.3))
    return correct_cycle(CorrectRequest(model, history=history), part, composite=LAYOUT.composite)


def test_no_register_is_held_when_the_forecast_leaves_the_centre() -> None:
    d = Diagnoser().run(LAYOUT, _random_walk(5))
    assert d.next_forecast is not None and d.centred is not None
    far = d.next_forecast + 0.5 * (LAYOUT.upper - LAYOUT.lower)  # the model predicts every dimension out
    recent = d.series.deviation[-2:]
    assert d.centred.any()
    assert not centred_registers(d.next_matrix(), recent, far, LAYOUT.lower, LAYOUT.upper).any()
