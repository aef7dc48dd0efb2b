"""Matching report characteristics to model dimensions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from setupfix.errors import MatchError
from setupfix.model import match_parts, model_from_dict


def small_model(**dim_extra):
    doc = {
        "process": {"name": "t"},
        "wks": {"W1": {}},
        "tools": {"T1": {}},
        "features": {"F1": {"wks": {"W1": 1}, "tools": {"T1": 1}}, "F2": {"wks": {"W1": 1}}},
        "dimensions": {
            "D1": {"name": "Bore  Depth", "aliases": ["CHAR-7"], "features": {"F1": 1}, "nominal": 10.0,
                   "lower": -0.05, "upper": 0.05, **dim_extra},
            "D2": {"name": "Face", "features": {"F2": 1}, "nominal": 5.0, "lower": -0.1, "upper": 0.1},
        },
    }
    return model_from_dict(doc, "m.toml")


def table(rows):
    return pd.DataFrame(rows)


def test_name_and_alias_ignore_case_and_spaces():
    model = small_model()
    parts = match_parts(model, table([
        {"characteristic": " bore depth", "deviation": 0.01, "unit": "mm", "source": "r.csv:2"},
        {"characteristic": "char-7", "deviation": 0.02, "unit": "mm", "source": "r.csv:3", "part": "b"},
    ]).fillna({"part": "a"}))
    assert [p.part for p in parts] == ["a", "b"]
    assert parts[0].deviation[0] == pytest.approx(0.01)
    assert parts[1].deviation[0] == pytest.approx(0.02)


def test_inch_converted_to_model_unit_and_absent_listed():
    model = small_model()
    (part,) = match_parts(model, table([{"characteristic": "Face", "deviation": 0.001, "unit": "inch"},
                                        {"characteristic": "Datum A", "deviation": 0.5, "unit": "mm"}]))
    assert part.deviation[1] == pytest.approx(0.0254)
    assert np.isnan(part.deviation[0]) and part.absent == ("D1",)
    assert part.unmatched == ("Datum A",)


def test_nothing_matches_is_an_error():
    with pytest.raises(MatchError, match="no characteristic"):
        match_parts(small_model(), table([{"characteristic": "X", "deviation": 0.1}]))


def test_measured_twice_is_an_error():
    rows = [{"characteristic": "Face", "deviation": 0.1, "source": "r.csv:2"},
            {"characteristic": "FACE", "deviation": 0.2, "source": "r.csv:5"}]
    with pytest.raises(MatchError, match=r"r\.csv:5.*measured twice.*r\.csv:2"):
        match_parts(small_model(), table(rows))


def test_repeated_names_told_apart_by_station():
    doc = {
        "process": {"name": "t"}, "wks": {"W1": {}, "W2": {}},
        "features": {"F1": {"wks": {"W1": 1}}, "F2": {"wks": {"W2": 1}}},
        "dimensions": {
            "A": {"name": "D1", "group": "P1", "features": {"F1": 1}, "nominal": 1, "lower": -1, "upper": 1},
            "B": {"name": "D1", "group": "P2", "features": {"F2": 1}, "nominal": 1, "lower": -1, "upper": 1},
        },
    }
    model = model_from_dict(doc)
    (part,) = match_parts(model, table([{"characteristic": "D1", "deviation": 0.1, "station": "p2"},
                                        {"characteristic": "D1", "deviation": 0.3, "station": "P1"}]))
    assert part.deviation.tolist() == pytest.approx([0.3, 0.1])
    with pytest.raises(MatchError, match="several dimensions"):
        match_parts(model, table([{"characteristic": "D1", "deviation": 0.1}]))
