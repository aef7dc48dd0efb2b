"""The declared-parameter checks every estimator family uses."""

from __future__ import annotations

import math
from typing import ClassVar

import pytest

from setupfix.core.errors import ParameterError, SetupfixError
from setupfix.core.params import Constraint, Interval, Options, Predicate, ValidatedParams, validate_params


class _Est(ValidatedParams):
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "n": [Interval(int, 1, 100)],
        "pa": [Interval(float, 0, 1, closed="neither")],
        "kind": [Options({"a", "b"})],
        "seed": [Interval(int, 0, None), None],
        "flag": [bool],
        "even": [Predicate(lambda v: v % 2 == 0, "an even number")],
    }

    def __init__(
        self,
        n: object = 1,
        pa: object = 0.5,
        kind: object = "a",
        seed: object = None,
        flag: object = False,
        even: object = 2,
    ) -> None:
        self.n, self.pa, self.kind, self.seed, self.flag, self.even = n, pa, kind, seed, flag, even


def test_defaults_pass() -> None:
    _Est().validate_params()


@pytest.mark.parametrize(
    ("kw", "text"),
    [
        ({"n": -5}, "n must be an int in [1, 100], got -5"),
        ({"n": 2.0}, "n must be an int"),
        ({"n": True}, "n must be an int"),
        ({"pa": 1.0}, "pa must be a number in (0, 1), got 1.0"),
        ({"pa": math.nan}, "pa must be a number"),
        ({"pa": math.inf}, "pa must be a number"),
        ({"kind": "c"}, "kind must be one of 'a', 'b', got 'c'"),
        ({"kind": ["a"]}, "kind must be one of"),
        ({"seed": -1}, "seed must be an int in [0, inf) or None, got -1"),
        ({"flag": 1}, "flag must be a bool, got 1"),
        ({"even": 3}, "even must be an even number, got 3"),
        ({"even": "x"}, "even must be an even number"),
    ],
)
def test_out_of_range_names_owner_parameter_and_range(kw: dict[str, object], text: str) -> None:
    with pytest.raises(ParameterError) as info:
        _Est(**kw).validate_params()
    assert str(info.value).startswith("_Est: ")
    assert text in str(info.value)
    assert isinstance(info.value, SetupfixError)


def test_unlisted_parameters_are_not_checked_but_listed_ones_are() -> None:
    validate_params("x", {"free": object()}, {})
    with pytest.raises(ParameterError):
        validate_params("x", {"n": 0}, {"n": [Interval(int, 1, None)]})
