"""setupfix.usecases.requests: the typed, frozen, hashable options of a request, checked when made."""

from __future__ import annotations

import pickle

import pytest
from conftest import SAMPLES

from setupfix.core.errors import ParameterError
from setupfix.model import load_model
from setupfix.usecases.requests import CorrectRequest, CurrentOffsets, CycleOptions, ReadOptions, SolveOptions


def test_requests_are_hashable_options_and_checked() -> None:
    assert CycleOptions.of({"A7": "P1"}).station_map() == {"A7": "P1"}
    assert CycleOptions.of(["P2", "P1"]).station_map() == ["P2", "P1"]
    hash(CycleOptions.of(["P1"], part="x"))
    assert SolveOptions(time_limit=1.5).params() == {"time_limit": 1.5}
    with pytest.raises(ParameterError, match="applies to the exact optimizer"):
        SolveOptions("pso", time_limit=1.0)
    with pytest.raises(ParameterError, match="unknown optimizer"):
        SolveOptions("magic")
    with pytest.raises(ParameterError, match=r"time_limit must be a number in \(0, inf\)"):
        SolveOptions(time_limit=0.0)  # the optimiser's own declared constraint, its own words


def test_current_offsets_are_a_frozen_mapping_with_their_source() -> None:
    model = load_model(SAMPLES / "controllers" / "model.toml")
    current = CurrentOffsets.read(SAMPLES / "controllers" / "current.csv", model)
    assert set(current) == set(model.register_ids) and len(current) == len(model.register_ids)
    assert current.source.endswith("current.csv") and hash(current) == hash(
        CurrentOffsets.of(dict(current), current.source)
    )
    with pytest.raises(KeyError):
        current["W9"]
    # wear registers only: their value is the total since the last reset
    assert set(current.wear_totals(model)) == {r.id for r in model.registers if r.offset == "wear"}


def test_a_request_pickles_to_an_equal_one() -> None:
    model = load_model(SAMPLES / "controllers" / "model.toml")
    req = CorrectRequest(
        model,
        ReadOptions(unit="mm"),
        CycleOptions.of({"A": "P1"}, part="A"),
        SolveOptions("pso", seed=3),
        CurrentOffsets.of({"W1": 0.5}, "c.csv"),
    )
    again = pickle.loads(pickle.dumps(req))
    assert again == req and again.cycles.station_map() == {"A": "P1"}
