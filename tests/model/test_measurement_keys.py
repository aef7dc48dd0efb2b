"""Issue 40's model keys: [measurement] U and MPE, the dimension's own U, dead band as "N %", mean_of, min_parts.

U's precedence and the MPE formula are checked against values computed here by hand.
"""

from __future__ import annotations

import copy
from typing import Any

import pytest

from setupfix.core.errors import ModelError, ParameterError
from setupfix.model import model_from_dict
from setupfix.model.safety import Rules, mpe_uncertainty, parse_rules

BASE: dict[str, Any] = {
    "process": {"name": "p"},
    "wks": {"W1": {"register": "G54"}},
    "tools": {"T5": {"register": "H5"}},
    "features": {"F1": {"wks": {"W1": 1}}, "F2": {"tools": {"T5": 1}}},
    "dimensions": {
        "D1": {"features": {"F1": 1}, "nominal": 250.0, "lower": -0.1, "upper": 0.1},
        "D2": {"features": {"F2": 1}, "nominal": -30.0, "lower": -0.05, "upper": 0.05},
        "D3": {"features": {"F1": 1, "F2": 1}, "nominal": 0.0, "lower": -0.2, "upper": 0.2},
    },
}


def doc(**tables: Any) -> dict[str, Any]:
    d = copy.deepcopy(BASE)
    for name, value in tables.items():
        if name.startswith("dim_"):
            d["dimensions"][name[4:]].update(value)
        else:
            d[name] = value
    return d


def test_mpe_formula_in_mm_and_inch() -> None:
    # MPE_E = a + L/b µm: 1.8 + 250/300 µm for L = 250 mm
    assert mpe_uncertainty(1.8, 300.0, 250.0) == pytest.approx((1.8 + 250 / 300) / 1000, rel=1e-12)
    assert mpe_uncertainty(1.8, 300.0, -250.0) == pytest.approx((1.8 + 250 / 300) / 1000, rel=1e-12)
    # a 10 inch nominal is 254 mm; U back in inch
    assert mpe_uncertainty(2.0, 400.0, 10.0, "inch") == pytest.approx((2.0 + 254 / 400) / 1000 / 25.4, rel=1e-12)


def test_precedence_dimension_then_measurement() -> None:
    m = model_from_dict(doc(measurement={"uncertainty": 0.003}, dim_D2={"uncertainty": 0.001}))
    s = m.safety
    assert s.dimension_uncertainty == {"D2": 0.001} and s.uncertainty == 0.003
    assert [s.source_of(d) for d in ("D1", "D2", "D3")] == ["measurement", "dimension", "measurement"]


def test_mpe_fills_only_dimensions_without_their_own() -> None:
    m = model_from_dict(doc(measurement={"mpe": [1.8, 300]}, safety={"dimensions": {"D3": {"uncertainty": 0.004}}}))
    s = m.safety
    assert s.dimension_uncertainty["D1"] == pytest.approx((1.8 + 250 / 300) / 1000)
    assert s.dimension_uncertainty["D2"] == pytest.approx((1.8 + 30 / 300) / 1000)
    assert s.dimension_uncertainty["D3"] == 0.004
    assert [s.source_of(d) for d in ("D1", "D2", "D3")] == ["mpe", "mpe", "dimension"]


def test_no_uncertainty_anywhere_is_the_old_model() -> None:
    s = model_from_dict(doc()).safety
    assert s.uncertainty == 0 and not s.dimension_uncertainty and s.source_of("D1") == ""
    assert s.rules() == Rules()


def test_mpe_leaving_no_zone_is_not_a_model_error() -> None:
    # a huge MPE: the CMM's own figure is a warning at correction time, never a refused model
    m = model_from_dict(doc(measurement={"mpe": [60.0, 1]}))
    assert m.safety.source_of("D2") == "mpe" and m.safety.dimension_uncertainty["D2"] > 0.05


@pytest.mark.parametrize(
    ("tables", "key"),
    [
        ({"measurement": {"uncertainty": -1.0}}, "measurement.uncertainty"),
        ({"measurement": {"mpe": [1.0]}}, "measurement.mpe"),
        ({"measurement": {"mpe": [1.0, 0]}}, "measurement.mpe"),
        ({"measurement": {"uncertainty": 0.001, "mpe": [1.0, 300]}}, "measurement.mpe"),
        ({"measurement": {"units": "mm"}}, "measurement.units"),
        ({"measurement": {"uncertainty": 0.001}, "safety": {"uncertainty": 0.002}}, "measurement.uncertainty"),
        ({"dim_D1": {"uncertainty": "big"}}, "dimensions.D1.uncertainty"),
        (
            {"dim_D1": {"uncertainty": 0.001}, "safety": {"dimensions": {"D1": {"uncertainty": 0.001}}}},
            "dimensions.D1.uncertainty",
        ),
        ({"dim_D2": {"uncertainty": 0.06}}, "uncertainty"),  # 2U ≥ the width 0.1: no zone (explicit: refused)
        ({"safety": {"dead_band": "ten %"}}, "safety.dead_band"),
        ({"safety": {"dead_band": "150 %"}}, "safety.dead_band"),
        ({"safety": {"mean_of": 0}}, "safety.mean_of"),
        ({"safety": {"mean_of": 3, "ewma": 0.5}}, "safety.mean_of"),
        ({"safety": {"min_parts": 1.5}}, "safety.min_parts"),
    ],
)
def test_bad_values_name_their_key(tables: dict[str, Any], key: str) -> None:
    with pytest.raises(ModelError) as err:
        model_from_dict(doc(**tables), "m.toml")
    assert "m.toml" in str(err.value) and key in str(err.value)


def test_rules_keys_are_read() -> None:
    d = doc(safety={"dead_band": "10 %", "gain": 0.5, "mean_of": 3, "min_parts": 2})
    d["wks"]["W1"].update({"dead_band": "5 %", "min_parts": 4})
    m = model_from_dict(d)
    assert m.safety.rules() == Rules(None, 0.1, 0.5, 3, 2)
    assert m.safety.dead_band is None and m.safety.dead_band_share == pytest.approx(0.1)
    w1 = m.register("W1").policy
    assert w1.dead_band is None and w1.dead_band_share == pytest.approx(0.05) and w1.min_parts == 4
    assert model_from_dict(doc(safety={"dead_band": 0.004})).safety.rules().dead_band == 0.004


def test_parse_rules() -> None:
    assert parse_rules("dead_band=10 %,gain=0.5,mean_of=3") == Rules(None, 0.1, 0.5, 3, 1)
    assert parse_rules("dead_band=0.002, min_parts=2") == Rules(0.002, None, 1.0, 1, 2)
    assert parse_rules("") == Rules()
    assert parse_rules("dead_band=10 %").to_json() == {"dead_band": "10 %", "gain": 1.0, "mean_of": 1, "min_parts": 1}
    for bad in ("gain=0", "gain=2", "mean_of=2.5", "speed=1", "dead_band", "gain=0.5,gain=0.4", "dead_band=x %"):
        with pytest.raises(ParameterError, match="--rules"):
            parse_rules(bad)
