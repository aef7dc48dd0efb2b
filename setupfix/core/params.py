"""Declared, validated hyper-parameters (scikit-learn's ``_parameter_constraints`` manner).

Every estimator family (optimisers, thermal methods) declares, per class, what each
``__init__`` parameter may be; :func:`validate_params` checks the values before any
work and raises one :class:`~setupfix.core.errors.ParameterError` naming the owner, the
parameter, the value and what is allowed.  The registries call it right after
construction, so a bad option fails before a file is read.

Example
-------
>>> class PSO(ValidatedParams):
...     _parameter_constraints = {"n_particles": [Interval(int, 1, 100_000)],
...                               "seed": [Interval(int, 0, None), None]}
...     def __init__(self, n_particles=100, seed=None):
...         self.n_particles, self.seed = n_particles, seed
>>> PSO(n_particles=-5).validate_params()
Traceback (most recent call last):
...
setupfix.core.errors.ParameterError: PSO: n_particles must be an int in [1, 100000], got -5
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from setupfix.core.errors import ParameterError

__all__ = ["Interval", "Options", "Predicate", "Constraint", "ValidatedParams", "validate_params", "describe"]


@dataclass(frozen=True)
class Interval:
    """A real or integer number in [left, right] (or open ends, ``None`` = unbounded).

    ``int`` accepts integral values only (``True``/``False`` are refused); ``float``
    accepts ints and floats, never NaN or ±inf.
    """

    type: type
    left: float | None
    right: float | None
    closed: str = "both"  # "both", "left", "right", "neither"

    def accepts(self, value: Any) -> bool:
        if isinstance(value, bool):
            return False
        if self.type is int:
            if not isinstance(value, numbers.Integral):
                return False
        elif not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
            return False
        v = float(value) if self.type is not int else int(value)
        if self.left is not None and (v < self.left or (v == self.left and self.closed in ("right", "neither"))):
            return False
        return not (
            self.right is not None and (v > self.right or (v == self.right and self.closed in ("left", "neither")))
        )

    def __str__(self) -> str:
        lo = "-inf" if self.left is None else f"{self.left:g}"
        hi = "inf" if self.right is None else f"{self.right:g}"
        lb = "[" if self.closed in ("both", "left") and self.left is not None else "("
        rb = "]" if self.closed in ("both", "right") and self.right is not None else ")"
        return f"{'an int' if self.type is int else 'a number'} in {lb}{lo}, {hi}{rb}"


@dataclass(frozen=True)
class Options:
    """One of a fixed set of values (strings, usually)."""

    values: frozenset[Any]

    def __init__(self, values: Iterable[Any]) -> None:
        object.__setattr__(self, "values", frozenset(values))

    def accepts(self, value: Any) -> bool:
        try:
            return value in self.values
        except TypeError:
            return False

    def __str__(self) -> str:
        return "one of " + ", ".join(repr(v) for v in sorted(self.values, key=str))


@dataclass(frozen=True)
class Predicate:
    """Any other rule: ``check(value) -> bool`` with its description."""

    check: Callable[[Any], bool]
    text: str

    def accepts(self, value: Any) -> bool:
        try:
            return bool(self.check(value))
        except Exception:  # noqa: BLE001 - a rule that cannot even look at the value refuses it
            return False

    def __str__(self) -> str:
        return self.text


#: A constraint is an Interval, Options, Predicate, a plain type (``bool``, ``str``…) or None
#: (the value None is allowed).
Constraint = Interval | Options | Predicate | type | None


def accepts(constraint: Constraint, value: Any) -> bool:
    if constraint is None:
        return value is None
    if isinstance(constraint, type):
        if constraint is bool:
            return isinstance(value, bool)
        return isinstance(value, constraint) and not isinstance(value, bool)
    return constraint.accepts(value)


def describe(constraints: list[Constraint]) -> str:
    """Human text of what a list of constraints allows."""
    parts = []
    for c in constraints:
        if c is None:
            parts.append("None")
        elif isinstance(c, type):
            parts.append(f"a {c.__name__}")
        else:
            parts.append(str(c))
    return " or ".join(parts)


def validate_params(owner: str, params: Mapping[str, Any], constraints: Mapping[str, list[Constraint]]) -> None:
    """Check ``params`` against ``constraints``; raise on the first value out of range.

    Parameters
    ----------
    owner : str
        Who the parameters belong to (``"PSO"``, ``"thermal method 'grey-cs'"``).
    params : mapping
        Parameter name → value.
    constraints : mapping
        Parameter name → list of allowed constraints (any one suffices).  A parameter
        without an entry is not checked; an entry ``"no_validation"`` is not supported
        on purpose: every parameter must say what it allows.

    Raises
    ------
    ParameterError
        ``"<owner>: <name> must be <allowed>, got <value!r>"``.
    """
    for name, value in params.items():
        allowed = constraints.get(name)
        if allowed is None:
            continue
        if not any(accepts(c, value) for c in allowed):
            raise ParameterError(f"{owner}: {name} must be {describe(allowed)}, got {value!r}")


class ValidatedParams:
    """Mixin: ``_parameter_constraints`` declared on the class, checked by ``validate_params``.

    Every name of ``get_params()`` must have an entry (a test over the registries
    checks this), so a new hyper-parameter cannot slip in unvalidated.
    """

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {}

    def get_params(self) -> dict[str, Any]:
        """Hyper-parameters as given to ``__init__`` (sklearn convention)."""
        return {k: v for k, v in vars(self).items() if not k.startswith("_")}

    def validate_params(self) -> None:
        """Raise :class:`ParameterError` if any hyper-parameter is out of its declared range."""
        validate_params(type(self).__name__, self.get_params(), self._parameter_constraints)
