"""The [effects] section: written, reloaded, replaced; the forecast `correct` uses."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import GUIDE_PINS

from setupfix.core.errors import ModelError
from setupfix.diagnose import Layout
from setupfix.diagnose.forecast import forecast_shift, relation_composite
from setupfix.model import ProcessModel, load_model, model_from_dict
from setupfix.model.effects import EffectsSection, ModelEffect, effects_from_dict
from setupfix.model.effects_toml import with_effects

SECTION = EffectsSection(
    (
        ModelEffect("E1", "drift", 0.002, 1e-5, "mm/h", "all tools ~ time"),
        ModelEffect("E2", "drift", 0.01, 1e-4, "mm", "sat", shape="saturating", tau=2.5),
        ModelEffect("E3", "wear", -0.0008, 1e-5, "mm/cycle", "T5 ~ parts since change", register="T5"),
        ModelEffect("E4", "relation", 0.5, 0.01, "1", "P2D3 ~ T23", register="T23", dimension="P2D3"),
        ModelEffect("E5", "group", 0.01, 0.001, "mm", "group P3", group="P3"),
        ModelEffect("E6", "thermal", 0.003, 1e-4, "mm/°C", "all tools ~ spindle", channel="spindle", reference=21.5),
        ModelEffect(
            "E7",
            "relation",
            0.4,
            0.01,
            "1",
            "P1D1 ~ one of W1, W2",
            register="W1",
            dimension="P1D1",
            registers=("W1", "W2"),
        ),
    ),
    origin="2026-11-02T06:00:00",
    cycle_hours=1 / 3,
    last_hours=10.0,
)


def test_written_section_reloads_equal_and_the_model_still_loads(
    tmp_path: Path, guide_pins_model: ProcessModel
) -> None:
    text = with_effects((GUIDE_PINS / "model.toml").read_text(encoding="utf-8"), SECTION)
    path = tmp_path / "aug.toml"
    path.write_text(text, encoding="utf-8")
    model = load_model(path)
    assert model.dimension_ids == guide_pins_model.dimension_ids
    back = effects_from_dict(tomllib.loads(text)["effects"], model)
    assert back == SECTION


def test_augmenting_twice_replaces_the_section_and_keeps_the_rest() -> None:
    base = (GUIDE_PINS / "model.toml").read_text(encoding="utf-8")
    once = with_effects(base, SECTION)
    smaller = EffectsSection(SECTION.effects[:1], SECTION.origin, SECTION.cycle_hours, SECTION.last_hours)
    twice = with_effects(once, smaller)
    assert twice == with_effects(base, smaller)
    assert twice.count("[effects]") == 1 and "[effects.E3]" not in twice
    assert twice.startswith(base.rstrip())


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"E1": {"kind": "creep", "estimate": 1.0}}, "effects.E1.kind"),
        ({"E1": {"kind": "wear", "estimate": 1.0, "register": "W1"}}, "effects.E1.register"),
        ({"E1": {"kind": "relation", "estimate": 1.0, "register": "T5", "dimension": "D99"}}, "effects.E1.dimension"),
        ({"E1": {"kind": "drift", "estimate": "x"}}, "effects.E1.estimate"),
        (
            {"E1": {"kind": "relation", "estimate": 1.0, "register": "T5", "dimension": "P1D1", "registers": ["X9"]}},
            "effects.E1.registers",
        ),
        ({"E1": {"kind": "drift", "shape": "saturating", "estimate": 1.0}}, "effects.E1.tau"),
    ],
)
def test_bad_effects_are_named_with_their_key(table: dict[str, Any], key: str, guide_pins_model: ProcessModel) -> None:
    with pytest.raises(ModelError) as err:
        effects_from_dict(table, guide_pins_model, "m.toml")
    assert f"m.toml: [{key}]" in str(err.value)


def test_forecast_shift_adds_drift_and_wear_until_the_next_cycle(guide_pins_model: ProcessModel) -> None:
    layout = Layout.from_model(guide_pins_model)
    C = layout.composite
    c_t = C[layout.tools].sum(axis=0)
    t, dt = 10.0, 1 / 3
    want = (0.002 * dt + 0.01 * (np.exp(-t / 2.5) - np.exp(-(t + dt) / 2.5))) * c_t - 0.0008 * C[
        layout.register_ids.index("T5")
    ]
    np.testing.assert_allclose(forecast_shift(SECTION, layout), want, atol=1e-15)
    assert not forecast_shift(EffectsSection(), layout).any()


def test_model_without_effects_loads_as_before(guide_pins_model: ProcessModel) -> None:
    doc = tomllib.loads((GUIDE_PINS / "model.toml").read_text(encoding="utf-8"))
    empty = model_from_dict({**doc, "effects": {}})
    assert not empty.effects.effects and empty.effects == EffectsSection()
    assert model_from_dict(doc) == empty


@pytest.mark.slow
def test_correct_maps_through_a_named_relation_only(tmp_path: Path, guide_pins_model: ProcessModel) -> None:
    """A relation whose register is named changes what the correction does; a shared one does not."""
    from setupfix.usecases.contract import note_lines
    from setupfix.usecases.correct import correct_report
    from setupfix.usecases.requests import CorrectRequest

    layout = Layout.from_model(guide_pins_model)
    C = relation_composite(SECTION, layout)
    delta = C - layout.composite
    i, q = layout.register_ids.index("T23"), layout.dimension_ids.index("P2D3")
    assert delta[i, q] == 0.5 and np.count_nonzero(delta) == 1  # E7 (W1 or W2) is not used
    weak = EffectsSection((dataclasses.replace(SECTION.effects[3], stderr=0.2),))  # 0.5 ± 0.2: not known to a third
    np.testing.assert_array_equal(relation_composite(weak, layout), layout.composite)
    path = tmp_path / "aug.toml"
    path.write_text(
        with_effects(
            (GUIDE_PINS / "model.toml").read_text(encoding="utf-8"),
            EffectsSection(SECTION.effects[3:4] + SECTION.effects[6:]),
        ),
        encoding="utf-8",
    )
    plain = correct_report(CorrectRequest(load_model(GUIDE_PINS / "model.toml")), GUIDE_PINS / "cycle_01.csv").cycles[0]
    aug = correct_report(CorrectRequest(load_model(path)), GUIDE_PINS / "cycle_01.csv").cycles[0]
    keep = plain.part.measured
    np.testing.assert_array_equal(aug.problem.composite, C[:, keep])
    np.testing.assert_array_equal(plain.problem.composite, layout.composite[:, keep])
    w0 = layout.composite[i, q]
    assert any(f"P2D3 ~ T23 {w0:g} → {w0 + 0.5:.4g}" in w for w in note_lines(aug.notes))
    assert not any("relation" in w for w in note_lines(plain.notes))
