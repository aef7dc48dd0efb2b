"""Length units of a QIF document: ``FileUnits`` and per-value ``linearUnit``.

QIF lengths are in the file's primary linear unit, which a value may override with
a ``linearUnit`` attribute (MBDVidia writes ``<MaxValue linearUnit="inch">``).  When
``FileUnits`` is absent the schema default is the metre — but the NIST MTC FAIR files
(``NIST_MTC_FAIR_Plate_Results_20parts.qif``) omit it while writing millimetres, so
the default is never applied silently (see :func:`choose_file_unit`).
"""

from __future__ import annotations

import math

from lxml import etree

from parsers.notes import note
from parsers.numbers import try_number
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS, length_factor

__all__ = ["unit_factor", "file_unit_factor", "choose_file_unit", "METRE_PLAUSIBLE_MAX"]

#: Largest nominal length [m] a part measured on a CMM plausibly has; a file without
#: ``FileUnits`` whose nominals exceed it is evidently not in metres.
METRE_PLAUSIBLE_MAX = 5.0

#: Unit names seen in ``UnitName``/``linearUnit`` beyond :data:`LENGTH_UNITS`.
_EXTRA_MM: dict[str, float] = {
    "m": 1000.0,
    "meter": 1000.0,
    "metre": 1000.0,
    "cm": 10.0,
    "micrometer": 0.001,
    "micron": 0.001,
    "um": 0.001,
    "ft": 304.8,
    "foot": 304.8,
}


def unit_factor(name: str) -> float | None:
    """Millimetres per unit ``name`` (case-insensitive), or None when unknown."""
    key = name.strip().lower()
    if key in LENGTH_UNITS:
        return length_factor(key, "mm")
    return _EXTRA_MM.get(key)


def file_unit_factor(root: etree._Element, ns: str, path: str) -> float | None:
    """Millimetres per file length unit from ``FileUnits/PrimaryUnits/LinearUnit``.

    Returns None when the document has no ``FileUnits`` linear unit.

    Raises
    ------
    ParseError
        If the unit is named but neither its name nor its conversion factor is usable.
    """
    unit = root.find(f"{{{ns}}}FileUnits/{{{ns}}}PrimaryUnits/{{{ns}}}LinearUnit")
    if unit is None:
        return None
    name = (unit.findtext(f"{{{ns}}}UnitName") or "").strip()
    factor = unit_factor(name) if name else None
    if factor is not None:
        return factor
    text = unit.findtext(f"{{{ns}}}UnitConversion/{{{ns}}}Factor")
    metres = try_number(text or "")
    if metres is not None and metres > 0:
        return metres * 1000.0
    if not name:
        # SI unit with no conversion: the value is in the SI unit itself (metre).
        si = (unit.findtext(f"{{{ns}}}SIUnitName") or "").strip().lower()
        if si in ("meter", "metre"):
            return 1000.0
    raise ParseError(
        f"unknown linear unit {name!r}", location=SourceLocation(path, line=unit.sourceline, element="FileUnits")
    )


def choose_file_unit(declared: float | None, nominals: list[float], path: str, unit: str | None) -> float:
    """Millimetres per file unit, applying the user's ``unit`` to files that declare none.

    Parameters
    ----------
    declared : float or None
        From :func:`file_unit_factor`.
    nominals : list of float
        Raw nominal values of length characteristics, in the file unit.
    path : str
        For messages.
    unit : str, optional
        ``--unit`` given by the user; used only when the file declares no unit.

    Raises
    ------
    ParseError
        If the file declares no unit, the user gave none and the values could be metres.
    """
    if declared is not None:
        return declared
    if unit:
        factor = unit_factor(unit)
        if factor is None:
            raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(path))
        return factor
    largest = max((abs(v) for v in nominals if math.isfinite(v)), default=0.0)
    if largest > METRE_PLAUSIBLE_MAX:
        note(
            f"no FileUnits; nominals up to {largest:g} cannot be metres, read as mm (give --unit to override)",
            SourceLocation(path, element="FileUnits"),
            "unit",
        )
        return 1.0
    raise ParseError(
        "no FileUnits: lengths would be metres by the QIF schema, but the values do not say which unit they are in",
        location=SourceLocation(path, element="FileUnits"),
        hint="give the unit with --unit mm or --unit inch",
    )
