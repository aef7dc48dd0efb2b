"""The link interface: what a protocol (OPC UA, LinuxCNC, …) offers to the use cases.

A :class:`Component` is one value of the control's offset table, named the way the process
model names it: the controller register (``G54``, ``H5``, ``D5``) and the axis (``X``, ``Y``,
``Z``, ``C`` for a work offset, LinuxCNC's rotation ``R``; ``length`` / ``radius`` for a tool's
registers).  A :class:`Link` reads and writes components in the control's own unit; the use
cases (:mod:`setupfix.usecases.machine`) do the unit conversion, the rounding to the control's
increment and the guarded write sequence, so every protocol only moves numbers.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import Protocol, runtime_checkable

__all__ = ["Component", "Link", "WKS_AXES", "TOOL_AXES", "LENGTH", "RADIUS"]

#: The axes a work offset component may name (``R``: LinuxCNC's XY rotation, degrees).
WKS_AXES = ("X", "Y", "Z", "C", "R")
LENGTH = "length"
RADIUS = "radius"
#: The "axes" of a tool's registers.
TOOL_AXES = (LENGTH, RADIUS)


@dataclass(frozen=True, slots=True, order=True)
class Component:
    """One value of the control's offset table.

    Parameters
    ----------
    register : str
        The controller register as the model names it (``"G54"``, ``"H5"``, ``"D5"``).
    axis : str
        ``"X"``, ``"Y"``, ``"Z"``, ``"C"`` (rotation, degrees) or ``"R"`` (LinuxCNC's XY
        rotation, degrees) for a work offset; ``"length"`` or ``"radius"`` for a tool register.
    """

    register: str
    axis: str

    def __post_init__(self) -> None:
        if not self.register.strip():
            raise ValueError("a component needs its register")
        if self.axis not in WKS_AXES + TOOL_AXES:
            raise ValueError(
                f"unknown axis {self.axis!r} of {self.register} (known: {', '.join(WKS_AXES + TOOL_AXES)})"
            )

    @property
    def rotation(self) -> bool:
        """True for a rotation (degrees, never converted between mm and inch)."""
        return self.axis in ("C", "R")

    @property
    def tool(self) -> bool:
        return self.axis in TOOL_AXES

    def __str__(self) -> str:
        return self.register if self.tool else f"{self.register}.{self.axis}"


@runtime_checkable
class Link(Protocol):
    """An open connection to one control's offset table (a context manager; :meth:`close` ends it).

    Values are in the control's unit (:attr:`unit`; rotations in degrees).  A link connects
    lazily or at open; it never retries a write on its own.

    Attributes
    ----------
    name : str
        For messages: the endpoint or instance and the link file, never a secret.
    unit : str
        ``"mm"`` or ``"inch"``: the unit of the control's values.
    increment : float
        The control's input increment in :attr:`unit` (> 0).
    machine : str or None
        The store's machine name for the audit (``[link] machine``), if the file gives it.
    """

    name: str
    unit: str
    increment: float
    machine: str | None

    def components(self) -> tuple[Component, ...]:
        """Every component the link can read (the map's, or the control's whole table)."""
        ...

    def read(self, components: Iterable[Component]) -> dict[Component, float]:
        """Current values, control unit.

        Raises
        ------
        LinkConfigError
            A component not mapped (all of them named; nothing read).
        LinkUnreachable, LinkLost, LinkDenied
        """
        ...

    def write(self, values: Mapping[Component, float]) -> None:
        """Write the values in order (already at the control's increment, control unit).

        Raises
        ------
        LinkLost
            The connection dropped mid-way (some values may be written).
        LinkDenied
            The control refused a node (the ones before it are written).
        """
        ...

    def interlocked(self) -> bool:
        """True when the control refuses offset writes now (program running, not in reset)."""
        ...

    def close(self) -> None: ...

    def __enter__(self) -> Link: ...

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None: ...
