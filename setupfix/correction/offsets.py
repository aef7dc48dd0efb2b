"""Offset rows: the corrections to type into (or send to) the controller.

One :class:`OffsetRow` per correctable register, zero included, so that the output is
a complete instruction ("leave H23 as it is" is an instruction too).  Without the
controller's current offsets a row says *add* ``delta``; with them it says *set*
``value = current + delta`` — an absolute value, so applying the file twice does not
apply the change twice.  Writing the rows in a file format is
:mod:`setupfix.outputs.controllers`' job (the offsets CSV's text, names escaped, is
:mod:`setupfix.outputs.writers`'); nothing here touches a file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from setupfix.core.errors import MatchError
from setupfix.model import ProcessModel

__all__ = ["grid_decimals", "format_value", "OFFSET_COLUMNS", "OffsetRow", "offset_rows"]

#: Columns of the offsets CSV, the spec's first (``../shared/spec/cli-json.md``).
OFFSET_COLUMNS = (
    "report",
    "part",
    "id",
    "register",
    "kind",
    "axis",
    "delta",
    "unit",
    "mode",
    "offset",
    "current",
    "value",
    "verdict",
)


def grid_decimals(resolution: float) -> int:
    """Decimals that show every multiple of the register resolution exactly (0…9)."""
    return max(0, min(9, math.ceil(-math.log10(resolution) - 1e-9)))


def format_value(value: float, decimals: int) -> str:
    """``value`` with at least ``decimals`` decimals and as many more (up to 9) as it needs.

    A controller's current offset may carry finer digits than the model's grid;
    they are kept, never rounded away.
    """
    exact = round(value, 9)
    d = decimals
    while d < 9 and round(exact, d) != exact:
        d += 1
    return f"{exact:.{d}f}"


@dataclass(frozen=True)
class OffsetRow:
    """One register change.

    Attributes
    ----------
    delta : float
        Change to add to the register [unit].
    mode : {"add", "set"}
        ``set`` when the current value is known: write ``value`` (= current + delta).
    offset : {"wear", "geometry"}
        Which offset of the register the change goes to (model, per register).
    number, edge : int or None
        Controller slot given in the model (else derived from ``register``).
    """

    report: str
    part: str
    id: str
    register: str
    kind: str
    axis: str
    delta: float
    unit: str = "mm"
    mode: str = "add"
    offset: str = "geometry"
    current: float | None = None
    value: float | None = None
    number: int | None = None
    edge: int | None = None
    resolution: float = 0.001
    verdict: str = ""

    def cells(self) -> list[str]:
        """The CSV cells in :data:`OFFSET_COLUMNS` order, numbers on the register grid."""
        d = grid_decimals(self.resolution)

        def num(v: float | None) -> str:
            return "" if v is None else format_value(v, d)

        return [
            self.report,
            self.part,
            self.id,
            self.register,
            self.kind,
            self.axis,
            num(self.delta),
            self.unit,
            self.mode,
            self.offset,
            num(self.current),
            num(self.value),
            self.verdict,
        ]


def offset_rows(
    model: ProcessModel,
    corrections: Mapping[str, float],
    *,
    report: str = "",
    part: str = "",
    current: Mapping[str, float] | None = None,
    verdict: str = "",
) -> list[OffsetRow]:
    """Rows for every correctable (non-fixed) register of ``model``, in model order.

    In a multi-axis model one row per register component: ``id`` the component ID (``W1.X``,
    ``W1.C``, ``T5``, ``T5.R``), ``axis`` the component (X, Y, Z, C; a tool length the spindle axis;
    R a radius), ``resolution`` :meth:`~setupfix.model.ProcessModel.resolution_of` (a C row in
    degrees).

    ``current`` maps register IDs to the controller's current values (all of them:
    see :func:`parsers.current.read_current`); rows become ``set`` rows.

    Raises
    ------
    MatchError
        If ``current`` is given but lacks a correctable register.
    """
    rows = []
    for reg in model.registers:
        if reg.fixed:
            continue
        policy = reg.policy
        resolution = model.resolution_of(reg)
        digits = grid_decimals(resolution)
        delta = round(float(corrections.get(reg.id, 0.0)), digits) + 0.0  # + 0.0 turns -0.0 into 0.0
        now = value = None
        if current is not None:
            if reg.id not in current:
                raise MatchError(f"no current value for register {reg.register} ({reg.id}) in the current offsets")
            now = float(current[reg.id]) + 0.0
            value = round(now + delta, 9) + 0.0
        rows.append(
            OffsetRow(
                report,
                part,
                reg.id,
                reg.register,
                reg.kind,
                reg.component or model.axis,
                delta,
                model.unit,
                "add" if current is None else "set",
                reg.offset,
                now,
                value,
                policy.number,
                policy.edge,
                resolution,
                verdict,
            )
        )
    return rows
