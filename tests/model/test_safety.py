"""The model's [safety] table (ProcessModel.safety) and per-register settings (Register.policy), typed."""

from __future__ import annotations

from typing import Any

import pytest

from setupfix.core.errors import ModelError
from setupfix.model import model_from_dict
from setupfix.model.safety import RegisterPolicy, SafetySettings

BASE: dict[str, dict[str, Any]] = {
    "process": {"name": "p"},
    "wks": {"W1": {"register": "G54"}},
    "tools": {"T5": {"register": "H5"}},
    "features": {"F1": {"wks": {"W1": 1}, "tools": {"T5": 1}}},
    "dimensions": {"D1": {"features": {"F1": 1}, "nominal": 1, "lower": -0.1, "upper": 0.1}},
}


def doc(**over: object) -> dict[str, Any]:
    d: dict[str, Any] = {
        k: {kk: dict(vv) if isinstance(vv, dict) else vv for kk, vv in v.items()} for k, v in BASE.items()
    }
    for path, value in over.items():
        table, _, key = path.rpartition("__")
        node = d
        for part in table.split("__"):
            node = node.setdefault(part, {})
        node[key] = value
    return d


def test_defaults_without_safety_table() -> None:
    m = model_from_dict(BASE)
    s = m.safety
    assert s == SafetySettings() and s.dead_band is None and s.gain == 1.0 and s.reject_band is None and s.ewma == 1.0
    t5 = m.register("T5")
    assert t5.policy == RegisterPolicy() and t5.cost == 1.0 and t5.policy.offset is None
    assert t5.offset == "wear" and m.register("W1").offset == "geometry"  # defaults by kind
    assert not m.effects and m.effects.effects == ()


def test_values_are_read() -> None:
    m = model_from_dict(
        doc(
            safety__gain=0.7,
            safety__dead_band=0.003,
            safety__uncertainty=0.002,
            tools__T5__cost=4,
            tools__T5__offset="geometry",
            tools__T5__number=5,
            wks__W1__cumulative_limit=0.3,
            safety__dimensions__D1__uncertainty=0.004,
            safety__dimensions__D1__reject_band=0.5,
        )
    )
    s = m.safety
    assert (s.gain, s.dead_band, s.uncertainty) == (0.7, 0.003, 0.002)
    t5 = m.register("T5").policy
    assert t5.cost == 4.0 and t5.offset == "geometry" and t5.number == 5 and m.register("T5").offset == "geometry"
    assert m.register("W1").policy.cumulative_limit == 0.3 and m.register("W1").cost == 1.0
    assert s.dimension_uncertainty == {"D1": 0.004} and s.dimension_reject_band == {"D1": 0.5}


def test_bad_values_are_listed_with_their_key_paths() -> None:
    with pytest.raises(ModelError) as info:
        model_from_dict(doc(tools__T5__cost=0, tools__T5__offset="both", tools__T5__number=-1), source="m.toml")
    text = str(info.value)
    for expected in (
        "m.toml: [tools.T5.cost]: expected a number in (0, ∞)",
        '[tools.T5.offset]: expected "wear" or',
        "[tools.T5.number]: expected a whole number",
    ):
        assert expected in text
    assert len(text.splitlines()) == 3
    with pytest.raises(ModelError) as info:
        model_from_dict(
            doc(
                safety__gain=1.5,
                safety__deadband=1,
                safety__dimensions__D1__uncertainty="x",
                safety__dimensions__D9__uncertainty=0.1,
            ),
            source="m.toml",
        )
    text = str(info.value)
    for expected in (
        "m.toml: [safety.gain]: expected a number in (0, 1]",
        "[safety.deadband]: unknown key",
        "[safety.dimensions.D1.uncertainty]: expected a number",
        "[safety.dimensions.D9]: unknown",
    ):
        assert expected in text
    assert len(text.splitlines()) == 4
