"""The level and process kinds: their fields, detection on simulated series, the [effects] round trip."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import ModelError
from setupfix.diagnose import Diagnoser, EffectSpec, HiddenEffect, Layout, Series, ShopSimulator, candidate_specs
from setupfix.diagnose.forecast import forecast_shift, spec_of
from setupfix.diagnose.terms import common_tool_row, effect_field
from setupfix.model import ProcessModel, load_model
from setupfix.model.effects import EffectsSection, ModelEffect, effects_from_dict
from setupfix.model.effects_toml import with_effects

LAYOUT = Layout.from_model(load_model(GUIDE_PINS / "model.toml"))


def _series(n: int = 6) -> Series:
    time = np.arange(n, dtype=float) / 2.0
    proc = np.column_stack([np.arange(n, dtype=float) * 1000.0, np.arange(n) % 2])
    return Series(
        np.zeros((n, LAYOUT.n_dimensions)),
        time,
        np.zeros((n, LAYOUT.n_registers)),
        np.zeros((n, LAYOUT.tools.size)),
        proc,
        ("speed", "batch=B"),
        (),
        "",
        np.zeros(0),
        ("speed", "batch=B"),
    )


def test_level_field_is_the_register_row_from_the_step_on() -> None:
    s = _series()
    t5 = LAYOUT.register_ids.index("T5")
    z = effect_field(EffectSpec("level", register="T5", at=1.5), LAYOUT, s)
    for k in range(s.n_cycles):  # brute force: cycles cut at or after 1.5 h carry C[T5]
        np.testing.assert_array_equal(z[k], LAYOUT.composite[t5] if s.time[k] >= 1.5 else 0.0)
    common = effect_field(EffectSpec("level", at=1.5), LAYOUT, s)
    np.testing.assert_array_equal(common[-1], common_tool_row(LAYOUT))


def test_process_field_is_channel_minus_reference_times_the_register_row() -> None:
    s = _series()
    w2 = LAYOUT.register_ids.index("W2")
    z = effect_field(EffectSpec("process", channel="speed", register="W2", reference=2000.0), LAYOUT, s)
    np.testing.assert_allclose(z, np.outer(s.temperature[:, 0] - 2000.0, LAYOUT.composite[w2]))
    assert EffectSpec("process", channel="speed", register="W2").target == "W2 ~ speed"
    assert EffectSpec("level", at=2.0, cycle="P7").target == "all tools step at P7"


def test_candidates_count_every_position_and_register_and_keep_process_off_thermal() -> None:
    s = _series(8)
    specs = candidate_specs(LAYOUT, s)
    levels = [c for c in specs if c.kind == "level"]
    # steps at cycles 2..6 (two cycles on each side), each common or on one of the registers
    assert sorted({c.at for c in levels}) == [1.0, 1.5, 2.0, 2.5, 3.0]
    assert len(levels) == 5 * (LAYOUT.n_registers + 1)
    proc = [c for c in specs if c.kind == "process"]
    assert {c.channel for c in proc} == {"speed", "batch=B"} and len(proc) == 2 * (LAYOUT.n_registers + 1)
    assert not [c for c in specs if c.kind == "thermal"]  # process channels are not temperatures
    assert len({c.at for c in candidate_specs(LAYOUT, _series(200), max_positions=10) if c.kind == "level"}) == 10


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize(
    ("spec", "magnitude"),
    [
        (EffectSpec("level", register="T5", at=5.0), 0.01),
        (EffectSpec("level", at=18.0), -0.008),
        (EffectSpec("process", channel="stickout_mm", register="T23", reference=37.5), 0.001),
        (EffectSpec("process", channel="speed_rpm", register="W3", reference=9000.0), 3e-6),
    ],
)
def test_hidden_level_and_process_effects_are_found_with_their_target(
    seed: int, spec: EffectSpec, magnitude: float
) -> None:
    sim = ShopSimulator(n_cycles=40, process=3, seed=seed).run(LAYOUT, [HiddenEffect(spec, magnitude)])
    d = Diagnoser(walk=False).run(LAYOUT, sim.series)
    assert [e.kind for e in d.effects] == [spec.kind]
    e = d.effects[0]
    assert e.spec.register == spec.register
    if spec.kind == "level":  # the step's cycle is the first one cut at or after it
        first = int(np.argmax(sim.series.time >= spec.at))
        assert e.spec.at == sim.series.time[first] and e.spec.cycle == sim.series.cycles[first]
    else:
        assert e.spec.channel == spec.channel
    assert abs(e.estimate - magnitude) < 4 * e.stderr


@pytest.mark.slow
def test_process_channels_and_nothing_hidden_give_no_effect() -> None:
    found = [
        Diagnoser(walk=False).run(LAYOUT, ShopSimulator(n_cycles=40, process=3, seed=s).run(LAYOUT).series).effects
        for s in range(10, 16)
    ]
    assert found == [()] * 6


@pytest.mark.slow
def test_a_set_of_registers_gets_a_coefficient_each() -> None:
    hidden = [
        HiddenEffect(EffectSpec("process", channel="stickout_mm", register="W2", reference=37.5), 0.0012),
        HiddenEffect(EffectSpec("process", channel="stickout_mm", register="T23", reference=37.5), -0.0007),
    ]
    sim = ShopSimulator(n_cycles=40, process=3, seed=5).run(LAYOUT, hidden)
    d = Diagnoser(walk=False).run(LAYOUT, sim.series)
    got = {e.spec.register: e for e in d.effects}
    assert {e.kind for e in d.effects} == {"process"} and set(got) == {"W2", "T23"}
    for h in hidden:
        e = got[h.spec.register]
        assert abs(e.estimate - h.magnitude) < 4 * e.stderr


SECTION = EffectsSection(
    (
        ModelEffect("E1", "level", 0.02, 0.001, "mm", "T5 step at P9", register="T5", at=3.0, cycle="P9"),
        ModelEffect("E2", "level", -0.01, 0.001, "mm", "all tools step at P4", at=1.0, cycle="P4"),
        ModelEffect(
            "E3",
            "process",
            2e-6,
            1e-7,
            "mm/unit of rpm",
            "W1 ~ rpm",
            channel="rpm",
            register="W1",
            reference=9000.0,
            span=6000.0,
        ),
        ModelEffect(
            "E4",
            "process",
            0.03,
            0.002,
            "mm/unit of len=Long",
            "all tools ~ len=Long",
            channel="len=Long",
            reference=0.5,
            span=1.0,
        ),
    ),
    origin="2026-11-02T06:00:00",
    cycle_hours=0.5,
    last_hours=10.0,
)


def test_level_and_process_round_trip_and_forecast(tmp_path: Path) -> None:
    text = with_effects((GUIDE_PINS / "model.toml").read_text(encoding="utf-8"), SECTION)
    path = tmp_path / "aug.toml"
    path.write_text(text, encoding="utf-8")
    model = load_model(path)
    assert effects_from_dict(tomllib.loads(text)["effects"], model) == SECTION == model.effects
    assert spec_of(SECTION.effects[0]) == EffectSpec("level", register="T5", at=3.0, cycle="P9")
    # a level is in the measured deviations already; a process channel unchanged forecasts nothing
    np.testing.assert_array_equal(forecast_shift(SECTION, LAYOUT, ahead=0.0), 0.0)
    got = forecast_shift(SECTION, LAYOUT, ahead=0.0, process_change={"rpm": 3000.0, "len=Long": 1.0})
    want = 2e-6 * 3000.0 * LAYOUT.composite[LAYOUT.register_ids.index("W1")] + 0.03 * common_tool_row(LAYOUT)
    np.testing.assert_allclose(got, want)


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"E1": {"kind": "level", "estimate": 0.1}}, "effects.E1.at"),
        ({"E1": {"kind": "level", "estimate": 0.1, "at": -1.0}}, "effects.E1.at"),
        ({"E1": {"kind": "level", "estimate": 11.0, "at": 1.0}}, "effects.E1.estimate"),
        ({"E1": {"kind": "level", "estimate": 0.1, "at": 1.0, "register": "X9"}}, "effects.E1.register"),
        ({"E1": {"kind": "process", "estimate": 0.1, "channel": "rpm"}}, "effects.E1.span"),
        ({"E1": {"kind": "process", "estimate": 0.01, "channel": "rpm", "span": 6000.0}}, "effects.E1.estimate"),
        ({"E1": {"kind": "process", "estimate": 0.01, "channel": "rpm", "span": 0.0}}, "effects.E1.span"),
        (
            {"E1": {"kind": "process", "estimate": 0.01, "channel": "rpm", "span": 1.0, "reference": 1e13}},
            "effects.E1.reference",
        ),
    ],
)
def test_bad_level_and_process_effects_are_named(
    table: dict[str, Any], key: str, guide_pins_model: ProcessModel
) -> None:
    with pytest.raises(ModelError) as err:
        effects_from_dict(table, guide_pins_model, "m.toml")
    assert f"m.toml: [{key}]" in str(err.value)


@pytest.mark.parametrize(
    "spec",
    [
        EffectSpec("level", register="T5"),  # at 0 h: every cycle alike, no step
        EffectSpec("process", channel="speed_rpm", register="T5"),
    ],
)  # no channel recorded
def test_simulator_refuses_an_effect_it_cannot_hide(spec: EffectSpec) -> None:
    from setupfix.core.errors import ParameterError

    with pytest.raises(ParameterError):
        ShopSimulator(n_cycles=10).run(LAYOUT, [HiddenEffect(spec, 0.01)])
