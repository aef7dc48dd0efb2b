"""The process model: registers, features and dimensions of one machining process.

A :class:`ProcessModel` is the six-tuple PM = (M, W, T, F, D, R) of Stryczek (2014),
with the relations R stored sparsely on the elements that receive them (a feature
knows which WKS and tools move it, a dimension which features enter it).  The dense
matrices R_MW, R_WF, R_TF, R_FD are built by :mod:`setupfix.correction.relation`.

All lengths are in ``ProcessModel.unit``.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from typing import Literal

from setupfix.model.effects import EffectsSection
from setupfix.model.safety import RegisterPolicy, SafetySettings

__all__ = [
    "RegisterKind",
    "Register",
    "MachinePoint",
    "Feature",
    "Dimension",
    "ProcessModel",
    "normalise_name",
]

RegisterKind = Literal["wks", "tool"]

_SPACES = re.compile(r"\s+")


@functools.lru_cache(maxsize=1 << 16)
def normalise_name(name: str) -> str:
    """Key used to match report characteristics with dimensions.

    Case is ignored and every run of white space counts as one blank
    (``"P1  d4 "`` matches ``"p1 D4"``).
    """
    return _SPACES.sub(" ", name.strip()).casefold()


@dataclass(frozen=True, slots=True)
class Register:
    """A correctable setup register: a work coordinate system or a tool length.

    Parameters
    ----------
    id : str
        Model ID (``W1``, ``T5``).
    kind : {"wks", "tool"}
    register : str
        Controller register (``G54``, ``H5``).
    limit : float
        Bound on the absolute correction [model unit].
    fixed : bool
        A fixed register is never corrected.
    policy : RegisterPolicy
        Its own settings: cost, offset type, controller slot, dead band, gain,
        cumulative limit (``None`` where the model-wide ``[safety]`` value applies).
    component : {"X", "Y", "Z", "C", "R"} or None
        In a multi-axis model (``../shared/spec/process-model.md``, *Multi-axis models*) each
        correctable register component is one :class:`Register`: a WKS translation (``W1.X``,
        component the axis), a WKS rotation about the spindle (``W1.C``, degrees), a tool length
        (``T5``, component the spindle axis) or a tool radius (``T5.R``, register e.g. ``D5``).
        ``None`` in a one-axis model, where every register acts along ``ProcessModel.axis``.
    owner : str or None
        In a multi-axis model the ``[wks.ID]`` / ``[tools.ID]`` table the component comes from
        (``W1`` for ``W1.X``); ``None`` in a one-axis model (see :attr:`base`).
    """

    id: str
    kind: RegisterKind
    register: str
    limit: float
    fixed: bool = False
    policy: RegisterPolicy = field(default_factory=RegisterPolicy)
    component: str | None = None
    owner: str | None = None

    @property
    def base(self) -> str:
        """The ``[wks.ID]`` / ``[tools.ID]`` table this register (component) comes from."""
        return self.owner if self.owner is not None else self.id

    @property
    def cost(self) -> float:
        """Weight of the register in the least-norm stage (Σ cost·x², eq. 9 weighted)."""
        return self.policy.cost

    @property
    def offset(self) -> str:
        """The offset the change goes to: ``"wear"`` or ``"geometry"``."""
        return self.policy.offset_type(self.kind)


@dataclass(frozen=True, slots=True)
class MachinePoint:
    """A machine point (level 0, set M): a row of R_MW."""

    id: str
    wks: dict[str, float] = field(default_factory=dict)


#: Component keys of a multi-axis feature's per-WKS weights (``wks = {W1 = {x = 1, y = -1}}``).
WKS_COMPONENTS: tuple[str, ...] = ("x", "y", "z", "c")


@dataclass(frozen=True, slots=True)
class Feature:
    """A machined feature: a column of R_WF and R_TF.

    In a multi-axis model (``../shared/spec/process-model.md``, *Multi-axis models*) ``wks``
    is empty and ``components`` holds, per WKS ID, the weights ``{"x", "y", "z", "c"}`` (a
    number in the file fills all four); ``tools`` holds the length weights (along the spindle)
    and ``radius`` the radius weights ρ_fT by tool ID.
    """

    id: str
    wks: dict[str, float] = field(default_factory=dict)
    tools: dict[str, float] = field(default_factory=dict)
    position: tuple[float, float, float] | None = None
    components: dict[str, dict[str, float]] = field(default_factory=dict)
    radius: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Dimension:
    """A toleranced dimension: a column of R_FD with its tolerance.

    ``lower`` and ``upper`` are signed deviations from ``nominal``
    (``lower < upper``); either may be infinite for a one-sided tolerance.
    ``sampled`` (model key ``sampled = true``): the dimension is not measured every
    cycle (a sampling plan), so a report without it does not hold the registers that
    move it (:func:`setupfix.correction.pose.pose_problem`, coverage).

    Multi-axis models only: ``direction`` is the measuring direction n_q (a unit vector:
    the dimension's ``axis`` or ``direction``); ``kind`` is ``"length"``, ``"size"`` (only
    radius changes move it) or ``"position"`` (a circular zone: ``components`` are the two
    report characteristics giving its deviations along the ``plane`` axes, ``diameter`` its
    size; ``lower`` is 0 and ``upper`` the radius, limits of the radial distance).
    """

    id: str
    name: str
    features: dict[str, float]
    nominal: float
    lower: float
    upper: float
    aliases: tuple[str, ...] = ()
    group: str | None = None
    sampled: bool = False
    kind: str = "length"
    direction: tuple[float, float, float] | None = None
    components: tuple[str, ...] = ()
    plane: tuple[str, ...] = ()
    diameter: float | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        """Normalised names this dimension answers to (a position zone: none, see :attr:`component_keys`)."""
        if self.kind == "position":
            return ()
        return tuple(dict.fromkeys(normalise_name(n) for n in (self.name, *self.aliases)))

    @property
    def component_keys(self) -> tuple[str, ...]:
        """Normalised names of a position zone's two component characteristics (empty otherwise)."""
        return tuple(normalise_name(n) for n in self.components)

    @property
    def zone(self) -> bool:
        """True for a circular position zone (``kind = "position"``)."""
        return self.kind == "position"


@dataclass(frozen=True, slots=True)
class ProcessModel:
    """One machining process on one axis (the model file, validated).

    Parameters
    ----------
    name : str
    axis : {"X", "Y", "Z"}
    unit : {"mm", "inch"}
    resolution : float
        Register grid step [unit]; corrections are whole multiples of it.
    wks, tools : tuple of Register
        Sets W and T, in file order.
    machines : tuple of MachinePoint
        Set M (may be empty).
    features : tuple of Feature
        Set F.
    dimensions : tuple of Dimension
        Set D.
    source : str
        The file it was loaded from (for messages).
    safety : SafetySettings
        The ``[safety]`` table, defaults filled in when the file has none.
    effects : EffectsSection
        The ``[effects]`` section ``diagnose --augment`` writes (empty when absent).
    axes : tuple of str
        ``process.axes`` of a multi-axis model (e.g. ``("X", "Y", "Z")``); empty in a one-axis model.
    spindle : {"X", "Y", "Z"}
        The spindle axis (tool lengths act along it); ``axis`` in a one-axis model.
    draft : bool
        ``[process] draft = true``: an unedited scaffold (``setupfix model init``); nothing is
        recommended from it until the user removes the key.
    machine : str, optional
        ``[process] machine``: the machine this process runs on, the history store's default
        machine for its records (``--machine`` overrides it).
    rotation_limit, rotation_resolution : float
        Bound and grid step of a WKS rotation component (``W1.C``) [degrees].
    """

    name: str
    axis: str
    unit: str
    resolution: float
    limit: float
    wks: tuple[Register, ...]
    tools: tuple[Register, ...]
    machines: tuple[MachinePoint, ...]
    features: tuple[Feature, ...]
    dimensions: tuple[Dimension, ...]
    source: str = "<model>"
    safety: SafetySettings = field(default_factory=SafetySettings)
    effects: EffectsSection = field(default_factory=EffectsSection)
    axes: tuple[str, ...] = ()
    spindle: str = "Z"
    draft: bool = False
    machine: str | None = None
    rotation_limit: float = 0.05
    rotation_resolution: float = 0.0001

    @property
    def multi_axis(self) -> bool:
        """True for a model with ``process.axes`` (register components, see :class:`Register`)."""
        return bool(self.axes)

    def resolution_of(self, register: Register) -> float:
        """Grid step of one register component: ``rotation_resolution`` [degrees] for a rotation
        (component ``"C"``), ``resolution`` [unit] for everything else."""
        return self.rotation_resolution if register.component == "C" else self.resolution

    @property
    def registers(self) -> tuple[Register, ...]:
        """The decision variables x = [W_1 … W_|W|, T_1 … T_|T|] (paper's notation)."""
        return self.wks + self.tools

    @property
    def register_ids(self) -> list[str]:
        return [r.id for r in self.registers]

    @property
    def dimension_ids(self) -> list[str]:
        return [d.id for d in self.dimensions]

    def register(self, key: str) -> Register:
        """Look a register up by model ID or controller name (case-insensitive).

        In a multi-axis model a controller name shared by several components (``G54`` of
        ``W1.X`` … ``W1.C``) names none of them: ``KeyError`` (give the component ID).
        """
        for reg in self.registers:
            if reg.id == key:
                return reg
        folded = key.strip().casefold()
        found = [reg for reg in self.registers if reg.register.casefold() == folded or reg.id.casefold() == folded]
        if len(found) == 1 or (found and not self.multi_axis):
            return found[0]
        raise KeyError(key)
