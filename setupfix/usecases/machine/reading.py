"""``machine read`` and ``--link``: the control's values, as offsets for ``correct`` or a ``--current`` CSV."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from setupfix.core.atomic import write_text
from setupfix.links.base import Component, Link
from setupfix.links.errors import (
    LinkConfigError,
)
from setupfix.links.mapping import decimals_of, model_components, to_model
from setupfix.links.snapshot import ControlSnapshot
from setupfix.model import ProcessModel
from setupfix.usecases.requests import CurrentOffsets

__all__ = ["ControlRead", "read_control", "current_from_link", "write_current_csv"]


# -- reading ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ControlRead:
    """What ``machine read`` read: the link, its unit, and every component's value (control unit)."""

    snapshot: ControlSnapshot
    ids: tuple[tuple[Component, str], ...] = ()  # the model's register ID of each component (with --model)

    def to_json(self) -> dict[str, Any]:
        s = self.snapshot
        ids = dict(self.ids)
        return {
            "machine": s.machine,
            "link": s.link,
            "unit": s.unit,
            "increment": s.increment,
            "components": [
                {"register": c.register, "axis": c.axis, "value": v, "unit": "deg" if c.rotation else s.unit}
                | ({"id": ids[c]} if c in ids else {})
                for c, v in s.values
            ],
        }


def read_control(link: Link, model: ProcessModel | None = None) -> ControlRead:
    """Read every component the link maps, or only the model's correctable ones (in the model's order).

    Raises
    ------
    LinkConfigError
        A model component the link does not map (all named; nothing read).
    LinkUnreachable, LinkLost, LinkDenied, LinkError
    """
    if model is None:
        comps = list(link.components())
        ids: tuple[tuple[Component, str], ...] = ()
    else:
        by_id = model_components(model)
        comps = list(dict.fromkeys(by_id.values()))
        ids = tuple((c, rid) for rid, c in by_id.items())
    values = link.read(comps)
    snapshot = ControlSnapshot.of(link.name, link.unit, link.increment, {c: values[c] for c in comps}, link.machine)
    return ControlRead(snapshot, ids)


def current_from_link(link: Link, model: ProcessModel) -> CurrentOffsets:
    """The model's current offsets read from the control (model unit), holding the snapshot for the plan."""
    read = read_control(link, model)
    values = read.snapshot.as_dict
    current = {rid: to_model(values[c], c, model.unit, link.unit) for rid, c in model_components(model).items()}
    return CurrentOffsets.of(current, link.name, read.snapshot)


def _number(value: float, digits: int) -> str:
    text = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def write_current_csv(read: ControlRead, model: ProcessModel, path: str | Path) -> None:
    """The read values as a ``--current`` CSV (``cli-json.md``, "Current offsets"): the model's registers,
    the model's unit; ``register,value`` for a one-axis model, ``register,axis,value`` for a multi-axis one.

    Raises
    ------
    LinkConfigError
        The read holds no value for a correctable register of the model.
    """
    values = read.snapshot.as_dict
    unit = read.snapshot.unit
    digits = decimals_of(read.snapshot.increment) + (4 if unit != model.unit else 0)
    lines = ["register,axis,value" if model.multi_axis else "register,value"]
    for reg in model.registers:
        if reg.fixed:
            continue
        comp = model_components(model)[reg.id]
        if comp not in values:
            raise LinkConfigError(f"no value of {comp} was read (model register {reg.id})")
        text = _number(to_model(values[comp], comp, model.unit, unit), digits)
        if model.multi_axis:
            axis = reg.component if reg.kind == "wks" and reg.component else ""
            lines.append(f"{reg.register},{axis},{text}")
        else:
            lines.append(f"{reg.register},{text}")
    write_text(path, "\n".join(lines) + "\n")
