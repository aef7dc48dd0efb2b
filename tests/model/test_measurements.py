"""Matching report characteristics to model dimensions."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from setupfix.core.errors import MatchError
from setupfix.model import ProcessModel, match_parts, model_from_dict


def small_model(**dim_extra: object) -> ProcessModel:
    doc = {
        "process": {"name": "t"},
        "wks": {"W1": {}},
        "tools": {"T1": {}},
        "features": {"F1": {"wks": {"W1": 1}, "tools": {"T1": 1}}, "F2": {"wks": {"W1": 1}}},
        "dimensions": {
            "D1": {
                "name": "Bore  Depth",
                "aliases": ["CHAR-7"],
                "features": {"F1": 1},
                "nominal": 10.0,
                "lower": -0.05,
                "upper": 0.05,
                **dim_extra,
            },
            "D2": {"name": "Face", "features": {"F2": 1}, "nominal": 5.0, "lower": -0.1, "upper": 0.1},
        },
    }
    return model_from_dict(doc, "m.toml")


def table(rows: list[dict[str, object]]) -> pd.DataFrame:
    return pd.DataFrame(rows)


def test_name_and_alias_ignore_case_and_spaces() -> None:
    model = small_model()
    parts = match_parts(
        model,
        table(
            [
                {"characteristic": " bore depth", "deviation": 0.01, "unit": "mm", "source": "r.csv:2"},
                {"characteristic": "char-7", "deviation": 0.02, "unit": "mm", "source": "r.csv:3", "part": "b"},
            ]
        ).fillna({"part": "a"}),
    )
    assert [p.part for p in parts] == ["a", "b"]
    assert parts[0].deviation[0] == pytest.approx(0.01)
    assert parts[1].deviation[0] == pytest.approx(0.02)


def test_inch_converted_to_model_unit_and_absent_listed() -> None:
    model = small_model()
    (part,) = match_parts(
        model,
        table(
            [
                {"characteristic": "Face", "deviation": 0.001, "unit": "inch"},
                {"characteristic": "Datum A", "deviation": 0.5, "unit": "mm"},
            ]
        ),
    )
    assert part.deviation[1] == pytest.approx(0.0254)
    assert np.isnan(part.deviation[0]) and part.absent == ("D1",)
    assert part.unmatched == ("Datum A",)


def test_nothing_matches_is_an_error() -> None:
    with pytest.raises(MatchError, match="no characteristic"):
        match_parts(small_model(), table([{"characteristic": "X", "deviation": 0.1}]))


def test_measured_twice_keeps_the_later_with_a_note() -> None:
    rows = [
        {"characteristic": "Face", "deviation": 0.1, "source": "r.csv:2"},
        {"characteristic": "FACE", "deviation": 0.2, "source": "r.csv:5"},
    ]
    (part,) = match_parts(small_model(), table(rows))
    assert part.deviation[1] == pytest.approx(0.2) and part.sources[1] == "r.csv:5"
    (note,) = part.notes
    assert "measured twice" in str(note) and str(note).startswith("r.csv:5") and "r.csv:2 ignored" in str(note)


def test_measured_twice_the_later_time_stamp_wins_over_file_order() -> None:
    rows = [
        {"characteristic": "Face", "deviation": 0.1, "source": "r.csv:2", "timestamp": "2026-11-02T09:00"},
        {"characteristic": "Face", "deviation": 0.2, "source": "r.csv:5", "timestamp": "2026-11-02T08:00"},
    ]
    (part,) = match_parts(small_model(), table(rows))
    assert part.deviation[1] == pytest.approx(0.1) and part.sources[1] == "r.csv:2"
    assert "r.csv:2 is used" in str(part.notes[0])


@pytest.mark.parametrize(
    ("report", "model_name"), [("P2-D3", "P2 D3"), ("SP_00_Z", "SP-00_Z"), ("p1d1", "P1 D1"), ("P1 D11", "P1 D1")]
)
def test_unmatched_names_get_the_closest_model_names(report: str, model_name: str) -> None:
    doc = {
        "process": {"name": "t"},
        "wks": {"W1": {}},
        "features": {"F1": {"wks": {"W1": 1}}},
        "dimensions": {
            f"D{i}": {"name": n, "features": {"F1": 1}, "nominal": 1, "lower": -1, "upper": 1}
            for i, n in enumerate(["P2 D3", "SP-00_Z", "P1 D1", "Z1", "P2 D4"])
        },
    }
    model = model_from_dict(doc)
    (part,) = match_parts(
        model, table([{"characteristic": report, "deviation": 0.1}, {"characteristic": "Z1", "deviation": 0.1}])
    )
    assert part.unmatched == (report,)
    assert part.suggestions[report][0] == model_name


def test_nothing_matches_suggests_names() -> None:
    with pytest.raises(MatchError, match=r"'face_' \(model: 'Face'\?\)"):
        match_parts(small_model(), table([{"characteristic": "face_", "deviation": 0.1}]))


def test_report_nominal_and_limits_are_kept_in_model_unit() -> None:
    (part,) = match_parts(
        small_model(),
        table(
            [
                {
                    "characteristic": "Face",
                    "deviation": 0.001,
                    "nominal": 0.2,
                    "lower": -0.004,
                    "upper": 0.004,
                    "unit": "inch",
                }
            ]
        ),
    )
    assert part.nominal is not None and part.upper is not None
    assert part.nominal[1] == pytest.approx(5.08) and part.upper[1] == pytest.approx(0.1016)
    assert np.isnan(part.nominal[0]) and part.units == ("", "inch")


def test_repeated_names_told_apart_by_station() -> None:
    doc = {
        "process": {"name": "t"},
        "wks": {"W1": {}, "W2": {}},
        "features": {"F1": {"wks": {"W1": 1}}, "F2": {"wks": {"W2": 1}}},
        "dimensions": {
            "A": {"name": "D1", "group": "P1", "features": {"F1": 1}, "nominal": 1, "lower": -1, "upper": 1},
            "B": {"name": "D1", "group": "P2", "features": {"F2": 1}, "nominal": 1, "lower": -1, "upper": 1},
        },
    }
    model = model_from_dict(doc)
    (part,) = match_parts(
        model,
        table(
            [
                {"characteristic": "D1", "deviation": 0.1, "station": "p2"},
                {"characteristic": "D1", "deviation": 0.3, "station": "P1"},
            ]
        ),
    )
    assert part.deviation.tolist() == pytest.approx([0.3, 0.1])
    with pytest.raises(MatchError, match="several dimensions"):
        match_parts(model, table([{"characteristic": "D1", "deviation": 0.1}]))
