"""A WKS turned about the spindle axis: the rotation effect, per-axis positions, lack of fit against position."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from bench.diagnose_rotation import held_out, plate, plate_doc, rigid_rms, rotated_plate
from setupfix.core.errors import ModelError
from setupfix.diagnose import Diagnoser, EffectSpec, Layout, Series
from setupfix.diagnose.forecast import spec_of
from setupfix.diagnose.terms import effect_field
from setupfix.model import model_from_dict
from setupfix.model.effects import EffectsSection, ModelEffect, effects_from_dict
from setupfix.model.effects_toml import effects_toml


def test_rotation_field_is_minus_theta_y_on_x_and_theta_x_on_y() -> None:
    layout = Layout.from_model(plate(12, 0))
    assert layout.rotation_ids == ("W1",)
    x, y = layout.coord[:, 0], layout.coord[:, 1]
    is_x = np.array([d.endswith("X") for d in layout.dimension_ids])
    np.testing.assert_allclose(layout.rotation[0], np.where(is_x, -y, x), atol=1e-12)


def test_no_rotation_effect_where_the_model_has_a_rotation_register() -> None:
    doc = plate_doc(12, 0)
    doc["process"]["rotation"] = True
    assert Layout.from_model(model_from_dict(doc, source="turned")).rotation_ids == ()


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_a_rotated_plate_names_the_rotation_sized_and_predicting_held_out_holes(seed: int) -> None:
    """θ 100–800 µrad about a centre off the origin, noise 0.006 mm: named, within 10 %, and the held-out half
    of the holes reaches the rigid fit's residual within 20 % (before: split into two half-size positions)."""
    theta = (100 + 140 * seed) * 1e-6
    doc = plate_doc(80, seed)
    layout = Layout.from_model(model_from_dict(doc, source="plate"))
    s = rotated_plate(layout, theta, seed)
    d = Diagnoser(walk=False).run(layout, s)
    assert d.effects and d.effects[0].kind == "rotation" and d.effects[0].target == "W1 ~ rotation"
    assert abs(d.effects[0].estimate - theta) < 0.1 * theta
    assert not any(e.kind == "position" for e in d.effects)
    shift_only, carried = held_out(doc, s, layout)
    assert carried <= 1.2 * rigid_rms(layout, s) < shift_only


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_a_plate_not_turned_names_nothing_and_notes_nothing(seed: int) -> None:
    layout = Layout.from_model(plate(80, seed))
    d = Diagnoser(walk=False).run(layout, rotated_plate(layout, 0.0, seed))
    assert not d.effects and not any("lack of fit against position" in n for n in d.notes)


@pytest.mark.slow
def test_structure_left_against_position_is_noted() -> None:
    layout = Layout.from_model(plate(80, 1))
    s = rotated_plate(layout, 400e-6, 1)
    (note,) = [n for n in Diagnoser(walk=False, max_effects=0).run(layout, s).notes if "lack of fit" in n]
    assert "along X/Y" in note


@pytest.mark.slow
def test_an_axis_scale_is_its_own_position_slope_beside_the_rotation() -> None:
    layout = Layout.from_model(plate(80, 2))
    s = rotated_plate(layout, 300e-6, 2)
    spec = EffectSpec("position", axis="x", along="x")
    field = effect_field(spec, layout, s)
    s = Series(s.deviation + 2e-4 * field, s.time, s.applied, s.parts, s.temperature)
    d = Diagnoser(walk=False).run(layout, s)
    found = {e.spec: e for e in d.effects}
    assert set(found) == {EffectSpec("rotation", register="W1"), spec}
    assert found[spec].target == "x-errors ~ x"
    assert abs(found[spec].estimate - 2e-4) < 4 * found[spec].stderr


def test_augment_writes_a_declared_rotation_that_loads_back() -> None:
    model = plate(12, 0)
    section = EffectsSection(
        (
            ModelEffect("E1", "rotation", 4e-4, 3e-6, "rad", "W1 ~ rotation", register="W1"),
            ModelEffect("E2", "position", 2e-4, 4e-6, "mm/mm", "x-errors ~ x", axis="x", along="x"),
        )
    )
    text = effects_toml(section)
    loaded = effects_from_dict(tomllib.loads(text)["effects"], model)
    assert [spec_of(e) for e in loaded.effects] == [
        EffectSpec("rotation", register="W1"),
        EffectSpec("position", axis="x", along="x"),
    ]
    with pytest.raises(ModelError, match=r"E1\.register"):
        effects_from_dict({"E1": {"kind": "rotation", "estimate": 1e-4, "register": "T1"}}, model)
