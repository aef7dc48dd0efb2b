"""Hand-built offset rows of a multi-axis correction (the rows :func:`setupfix.correction.offsets.offset_rows` gives a
multi-axis model: one per register component), for the controller tests."""

from __future__ import annotations

from typing import TYPE_CHECKING

from setupfix.correction.offsets import OffsetRow

if TYPE_CHECKING:
    from setupfix.model import ProcessModel
    from setupfix.model.process import RegisterKind

__all__ = ["row", "fixture_rows", "SPEC"]


def row(
    id: str,
    register: str,
    kind: str,
    axis: str,
    delta: float,
    current: float | None = None,
    *,
    offset: str = "geometry",
    resolution: float = 0.001,
    unit: str = "mm",
    number: int | None = None,
    edge: int | None = None,
) -> OffsetRow:
    """One component's row: *add* without ``current``, else *set* with value = current + delta."""
    value = None if current is None else round(current + delta, 9) + 0.0
    return OffsetRow(
        "r.csv",
        "P1",
        id,
        register,
        kind,
        axis,
        delta,
        unit,
        "add" if current is None else "set",
        offset,
        current,
        value,
        number,
        edge,
        resolution,
        "apply",
    )


#: (component id, kind, axis, delta, current, offset, resolution) of a two-station fixture: G54 and G55 on
#: X/Y/Z with G54's rotation, a third WKS, tool 5 length and radius (wear), tool 12 length and radius.
SPEC = [
    ("W1.X", "wks", "X", 0.012, -250.123, "geometry", 0.001),
    ("W1.Y", "wks", "Y", -0.008, 120.5, "geometry", 0.001),
    ("W1.Z", "wks", "Z", -0.022, -412.53, "geometry", 0.001),
    ("W1.C", "wks", "C", 0.015, 0.25, "geometry", 0.001),
    ("W2.X", "wks", "X", 0.0, 50.0, "geometry", 0.001),
    ("W2.Y", "wks", "Y", 0.004, -0.5, "geometry", 0.001),
    ("W2.Z", "wks", "Z", 0.022, -412.487, "geometry", 0.001),
    ("W3.X", "wks", "X", -0.001, 10.0, "geometry", 0.001),
    ("W3.Y", "wks", "Y", 0.002, 20.0, "geometry", 0.001),
    ("W3.Z", "wks", "Z", 0.003, -30.0, "geometry", 0.001),
    ("T5", "tool", "Z", -0.008, -0.012, "wear", 0.001),
    ("T5.R", "tool", "R", -0.004, 0.002, "wear", 0.001),
    ("T12", "tool", "Z", 0.002, 125.0035, "geometry", 0.001),
    ("T12.R", "tool", "R", 0.001, 5.0, "geometry", 0.001),
]

#: Register of each component's register, by controller.
REGISTERS = {
    "fanuc": {"W1": "G54", "W2": "G55", "W3": "G54.1 P7", "T5": "H5", "T5.R": "D5", "T12": "H12", "T12.R": "D12"},
    "haas": {"W1": "G54", "W2": "G55", "W3": "G154 P7", "T5": "H5", "T5.R": "D5", "T12": "H12", "T12.R": "D12"},
    "siemens": {
        "W1": "G54",
        "W2": "G55",
        "W3": "G505",
        "T5": "T5 D1",
        "T5.R": "T5 D1",
        "T12": "T12 D2",
        "T12.R": "T12 D2",
    },
    "heidenhain": {
        "W1": "PRESET 1",
        "W2": "PRESET 2",
        "W3": "PRESET 7",
        "T5": "T5",
        "T5.R": "T5",
        "T12": "T12",
        "T12.R": "T12",
    },
    "csv": {"W1": "G54", "W2": "G55", "W3": "G54.1 P7", "T5": "H5", "T5.R": "D5", "T12": "H12", "T12.R": "D12"},
}


def fixture_rows(
    controller: str, mode: str, *, rotation: float | None = None, wks_only: bool = False
) -> list[OffsetRow]:
    """The rows of :data:`SPEC` with ``controller``'s registers, *add* or *set*; ``rotation`` replaces W1.C's
    change (None: keep it)."""
    out = []
    for cid, kind, axis, delta, current, offset, resolution in SPEC:
        if wks_only and kind != "wks":
            continue
        if cid == "W1.C" and rotation is not None:
            delta = rotation
        key = cid if cid in REGISTERS[controller] else cid.split(".")[0]
        out.append(
            row(
                cid,
                REGISTERS[controller][key],
                kind,
                axis,
                delta,
                current if mode == "set" else None,
                offset=offset,
                resolution=resolution,
                unit="mm",
            )
        )
    return out


def multi_axis_model(unit: str = "mm") -> ProcessModel:  # imported lazily: the rows need no model
    """A multi-axis model built directly (the loader of ``process.axes`` is another part's): G54 on X/Y/Z with its
    rotation, G55 on X/Y/Z, tool 5 length (H5) and radius (D5), a fixed tool 7."""
    from setupfix.model import ProcessModel, Register

    def reg(id: str, kind: RegisterKind, register: str, component: str, fixed: bool = False) -> Register:
        return Register(id, kind, register, 0.5, fixed, component=component)

    wks = (*(reg(f"W1.{a}", "wks", "G54", a) for a in "XYZC"), *(reg(f"W2.{a}", "wks", "G55", a) for a in "XYZ"))
    tools = (reg("T5", "tool", "H5", "Z"), reg("T5.R", "tool", "D5", "R"), reg("T7", "tool", "H7", "Z", fixed=True))
    return ProcessModel("multi", "Z", unit, 0.001, 0.5, wks, tools, (), (), (), axes=("X", "Y", "Z"), spindle="Z")
