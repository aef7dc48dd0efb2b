"""DMIS output (``.dmo``) → the canonical measurement table.

A DMIS output file lists nominal features and tolerances (``F(x)=FEAT/…``,
``T(x_X)=TOL/CORTOL,XAXIS,lo,hi``) and, later, the actual features and tolerance
results (``FA(x)=FEAT/…``, ``TA(x_X)=TOL/CORTOL,XAXIS,dev,INTOL``).  One row is made
per ``TA`` result.  The deviation is recomputed from ``FA`` − ``F`` where both give the
value and cross-checked against the ``TA`` number: some writers put the actual there
instead of the deviation, which is recognised; any other contradiction is an error.

A ``TA`` label need not match its ``T`` label (``TA(SP_00_DN)`` for
``T(SP_00_PROFP)``, ``T(Rectángulo_12_HEI)`` vs ``…_HEIGHT`` in the real samples), so
a result without a same-named tolerance takes the one tolerance of the same type and
axis defined for the same feature.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from parsers.axes import axis_word, vector_axis
from parsers.canonical import finish_table
from parsers.dmis.statements import Statement, parse_statement, split_statements
from parsers.geometry import axis_vector, geometry_cells, unit_vector
from parsers.notes import note
from parsers.numbers import is_number
from parsers.source import point_number, read_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import LENGTH_UNITS, length_factor
from setupfix.model.measurements import (
    ACTUAL_POSITION_COLUMNS,
    DATUMS_COLUMN,
    FEATURE_DIRECTION_COLUMNS,
    FEATURE_ID_COLUMN,
)

__all__ = ["read_dmis", "sniff_dmis"]

_AXES = {"XAXIS": 0, "YAXIS": 1, "ZAXIS": 2}
_DATE = re.compile(r"^DATE\s*=\s*(\d{4})/(\d{1,2})/(\d{1,2})\s*$", re.IGNORECASE)
_TIME = re.compile(r"^TIME\s*=\s*(\d{1,2}):(\d{2}):(\d{2})\s*$", re.IGNORECASE)
_STATUS = {"INTOL", "OUTOL", "OUTTOL"}
#: Tolerances whose result is a signed deviation from a profile (nominal 0).
_PROFILE = {"PROFP", "PROFS", "PROFL"}
#: Tolerances whose result is a zone size (nominal 0, upper limit = the zone).
_ZONE = {
    "POS",
    "FLAT",
    "PERP",
    "PARLEL",
    "ANGLR",
    "CIRLTY",
    "CYLCTY",
    "STRGHT",
    "CONCEN",
    "COAXL",
    "RNDOUT",
    "TRNOUT",
    "SYM",
}
#: Tolerances whose result is the measured size itself.
_SIZE = {"DIAM", "RAD"}


def sniff_dmis(text: str) -> bool:
    """True when the text starts like a DMIS program or output. Never raises."""
    head = text.lstrip("\ufeff").lstrip()[:2048].upper()
    return head.startswith(("DMISMN/", "DMISMD/")) or ("\nFA(" in head and "=FEAT/" in head)


@dataclass
class _Feature:
    line: int
    kind: str
    values: list[str]
    tolerances: list[str] = field(default_factory=list)
    #: ``INNER`` / ``OUTER`` (a bore / a boss) where the statement says so, else "".
    side: str = ""
    #: What :func:`_position` and :func:`_feature_direction` read from it, once per feature.
    cache: dict[str, tuple[float, float, float]] = field(default_factory=dict)


def _side(words: tuple[str, ...]) -> str:
    upper = {w.strip().upper() for w in words}
    return "inner" if "INNER" in upper else "outer" if "OUTER" in upper else ""


def _numbers_after_cart(words: tuple[str, ...]) -> list[str]:
    upper = [w.upper() for w in words]
    return list(words[upper.index("CART") + 1 :]) if "CART" in upper else []


def _geometry(feature: _Feature | None, axis: str, where: SourceLocation) -> float:
    """Coordinate or size of a feature named by a CORTOL axis word; NaN when unknown."""
    if feature is None:
        return math.nan
    nums = feature.values
    index = _AXES.get(axis)
    if index is None and axis in ("DIAMETER", "DIAM"):
        index = {"SPHERE": 3, "CIRCLE": 6, "CYLNDR": 6, "CYLINDER": 6, "ARC": 6}.get(feature.kind)
    if index is None or index >= len(nums):
        return math.nan
    return point_number(nums[index], SourceLocation(where.path, line=feature.line))


def read_dmis(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a DMIS output file (``.dmo``) into the canonical table.

    Parameters
    ----------
    path : str or Path
        The DMIS output file.
    unit : {"mm", "inch"}, optional
        Unit when the file has no ``UNITS/`` statement (default mm, with a warning).
    encoding : str, optional
        Text encoding; sniffed when omitted.

    Raises
    ------
    ParseError
        On a malformed number, a ``TA`` value that contradicts ``FA`` − ``F``, or a file
        without tolerance results; names file and line.
    """
    name = str(path)
    statements = [parse_statement(n, s) for n, s in split_statements(read_text(path, encoding))]
    factor: float | None = None
    nominal: dict[str, _Feature] = {}
    actual: dict[str, _Feature] = {}
    tols: dict[str, Statement] = {}
    results: list[tuple[Statement, str, str]] = []
    current_f = current_fa = ""
    part = date = time = datum = ""
    for st in statements:
        where = SourceLocation(name, line=st.line)
        if st.kind == "D" or (st.kind == "RECALL" and st.words and st.words[0].upper().startswith("D(")):
            # Results are in the active datum system; in a multi-station fixture each
            # station has its own (its own work offset), so its label names the station.
            datum = st.label if st.kind == "D" else st.words[0][2:].rstrip(")").strip()
        elif st.kind in ("PARTSN", "PARTID") and st.words:
            if st.kind == "PARTSN" or not part:
                part = st.words[0].strip().strip("'")
        elif date_match := _DATE.match(st.text):
            date = "{:04d}-{:02d}-{:02d}".format(*map(int, date_match.groups()))
        elif time_match := _TIME.match(st.text):
            time = "{:02d}:{:02d}:{:02d}".format(*map(int, time_match.groups()))
        elif st.kind == "UNITS" and st.words:
            word = st.words[0].strip().lower()
            if word not in LENGTH_UNITS:
                raise ParseError(f"unknown length unit {st.words[0]!r} in UNITS", location=where)
            factor = length_factor(word, "mm")
        elif st.kind == "OUTPUT":
            first = st.words[0] if st.words else ""
            label = first.partition("(")[2].rstrip(")") if first.upper().startswith(("F(", "FA(")) else ""
            if first.upper().startswith("FA("):
                current_fa = label
            elif first.upper().startswith("F("):
                current_f = label
        elif st.major == "FEAT" and st.kind in ("F", "FA"):
            kind = st.words[0].upper() if st.words else ""
            feature = _Feature(st.line, kind, _numbers_after_cart(st.words), side=_side(st.words))
            if st.kind == "F":
                nominal[st.label], current_f = feature, st.label
            else:
                actual[st.label], current_fa = feature, st.label
        elif st.major == "TOL" and st.kind == "T":
            tols[st.label] = st
            if current_f in nominal:
                nominal[current_f].tolerances.append(st.label)
        elif st.major == "TOL" and st.kind == "TA":
            results.append((st, current_fa, datum))
    if not results:
        raise ParseError(
            "no tolerance results (TA statements): a DMIS program or an output without results",
            location=SourceLocation(name),
        )
    if factor is None:
        factor = length_factor(unit or "mm", "mm")
        if unit is None:
            note("no UNITS statement, lengths read as mm", SourceLocation(name), "unit")
    tolerance = 0.0011 if factor == 1.0 else 0.00011
    rows: list[dict[str, object]] = []
    skipped: list[str] = []
    for st, feat, station in results:
        row = _result_row(st, feat, nominal, actual, tols, name, tolerance)
        if row is None:
            skipped.append(st.label)
            continue
        for col in ("nominal", "actual", "lower", "upper", "x", "y", "z", *ACTUAL_POSITION_COLUMNS):
            row[col] = float(row[col]) * factor  # type: ignore[arg-type]  # numbers in these columns
        row["part"], row["station"] = part, station
        row["timestamp"] = f"{date}T{time}" if date and time else date
        rows.append(row)
    if skipped:
        shown = ", ".join(skipped[:5]) + (", …" if len(skipped) > 5 else "")
        note(
            f"skipped {len(skipped)} result(s) whose nominal the file does not give: {shown}",
            SourceLocation(name),
            "skipped",
        )
    if not rows:
        raise ParseError("no tolerance result with a usable nominal", location=SourceLocation(name))
    return finish_table(rows, name)


def _matching_tolerance(
    st: Statement, feat: str, nominal: dict[str, _Feature], tols: dict[str, Statement]
) -> Statement | None:
    if st.label in tols:
        return tols[st.label]
    if feat not in nominal:
        return None
    key = (
        tuple(w.upper() for w in st.words[:2])
        if st.words and st.words[0].upper() == "CORTOL"
        else tuple(w.upper() for w in st.words[:1])
    )
    same = [
        tols[t]
        for t in nominal[feat].tolerances
        if t in tols and tuple(w.upper() for w in tols[t].words[: len(key)]) == key
    ]
    return same[0] if len(same) == 1 else None


def _result_row(
    st: Statement,
    feat: str,
    nominal: dict[str, _Feature],
    actual: dict[str, _Feature],
    tols: dict[str, Statement],
    name: str,
    tolerance: float,
) -> dict[str, object] | None:
    where = SourceLocation(name, line=st.line)
    words = [w.strip() for w in st.words]
    kind = words[0].upper() if words else ""
    status = next((w.upper() for w in words if w.upper() in _STATUS), "")  # before MMC, DAT(A), … in POS
    values = [w for w in words[1:] if w and w.upper() not in _STATUS]
    tol = _matching_tolerance(st, feat, nominal, tols)
    f_nom, f_act = nominal.get(feat), actual.get(feat)
    lower = upper = math.nan
    if kind == "CORTOL":
        if len(values) < 2:
            raise ParseError("CORTOL result needs an axis and a deviation", location=where)
        axis, reported = values[0].upper(), point_number(values[1], where, allow_empty=False)
        if tol is not None and len(tol.words) >= 4:
            tw = SourceLocation(name, line=tol.line)
            lower, upper = point_number(tol.words[2], tw), point_number(tol.words[3], tw)
        nom, act = _geometry(f_nom, axis, where), _geometry(f_act, axis, where)
        if math.isnan(nom) and math.isnan(act):
            return None
        if math.isnan(nom):
            nom = act - reported
        elif math.isnan(act):
            act = nom + reported
        elif abs((act - nom) - reported) > tolerance and abs(act - reported) > tolerance:
            # neither the deviation nor (another writer's) actual
            raise ParseError(f"{st.label}: result {reported:g} contradicts FA - F = {act - nom:g}", location=where)
    elif kind in _PROFILE or kind in _ZONE:
        numeric = [v for v in values if _is_number(v)]
        if not numeric:
            raise ParseError(f"{kind} result without a value", location=where)
        nom, act = 0.0, point_number(numeric[0], where)
        limits = (
            [point_number(v, SourceLocation(name, line=tol.line)) for v in tol.words[1:] if _is_number(v)]
            if tol is not None
            else []
        )
        if kind in _PROFILE and len(limits) >= 2:
            lower, upper = limits[0], limits[1]
        elif kind in _PROFILE and len(limits) == 1:
            lower, upper = -limits[0] / 2, limits[0] / 2
        elif limits:
            upper = abs(limits[0])
    elif kind in _SIZE:
        numeric = [v for v in values if _is_number(v)]
        nom = _geometry(f_nom, "DIAMETER", where) if kind == "DIAM" else math.nan
        if not numeric or math.isnan(nom):
            return None
        act = point_number(numeric[0], where)
        limits = (
            [point_number(v, SourceLocation(name, line=tol.line)) for v in tol.words[1:] if _is_number(v)]
            if tol is not None
            else []
        )
        if len(limits) >= 2:
            lower, upper = limits[0], limits[1]
    else:
        return None
    if not math.isnan(lower) and not math.isnan(upper) and lower > upper:
        raise ParseError(f"lower limit {lower:g} is above upper limit {upper:g}", location=where)
    x, y, z = _position(f_nom, name)
    x_act, y_act, z_act = _position(f_act, name)
    return {
        "characteristic": st.label,
        "nominal": nom,
        "actual": act,
        "lower": lower,
        "upper": upper,
        "x": x,
        "y": y,
        "z": z,
        "status": status,
        "source": f"{name}:{st.line}",
        "axis": _axis(kind, values, f_nom, name),
        **_geometry_cells(kind, values, f_nom or f_act, name),
        "x_actual": x_act,
        "y_actual": y_act,
        "z_actual": z_act,
        **dict(zip(FEATURE_DIRECTION_COLUMNS, _feature_direction(f_nom, name), strict=True)),
        FEATURE_ID_COLUMN: feat if f_nom is not None or f_act is not None else "",
        DATUMS_COLUMN: _datums(tol),
    }


def _position(feature: _Feature | None, name: str) -> tuple[float, float, float]:
    """The ``CART`` x, y, z of a feature (its location, a cylinder's or cone's axis point), file unit; NaN
    when the feature is unknown or states fewer than three values."""
    if feature is None or len(feature.values) < 3:
        return (math.nan, math.nan, math.nan)
    if "position" not in feature.cache:
        loc = SourceLocation(name, line=feature.line)
        x, y, z = (point_number(v, loc) for v in feature.values[:3])
        feature.cache["position"] = (x, y, z)
    return feature.cache["position"]


#: Features whose ``CART,x,y,z,i,j,k`` gives their own direction (i, j, k): a point's, edge point's or
#: plane's normal, a circle's or arc's normal, a cylinder's or cone's axis.
_DIRECTED_FEATURES = {"POINT", "EDGEPT", "PLANE", "CIRCLE", "ARC", "CYLNDR", "CYLINDER", "CONE"}
#: Largest departure of a stated unit vector's length from 1 that is still read as a direction.
_UNIT_TOLERANCE = 1e-3


def _feature_direction(feature: _Feature | None, name: str) -> tuple[float, float, float]:
    """The nominal feature's own direction (i, j, k) as a unit vector; NaN where it states none (empty
    words, as ``CIRCLE,INNER,CART,32.5,75.5,-10,,,,15`` has) or a vector whose length is not 1."""
    nan = (math.nan, math.nan, math.nan)
    if feature is None or feature.kind not in _DIRECTED_FEATURES or len(feature.values) < 6:
        return nan
    if "direction" not in feature.cache:
        feature.cache["direction"] = _direction_of(feature, name)
    return feature.cache["direction"]


def _direction_of(feature: _Feature, name: str) -> tuple[float, float, float]:
    nan = (math.nan, math.nan, math.nan)
    words = feature.values[3:6]
    if not all(w.strip() for w in words):
        return nan
    loc = SourceLocation(name, line=feature.line)
    vector = [point_number(w, loc) for w in words]
    norm = math.sqrt(sum(v * v for v in vector))
    if not abs(norm - 1.0) <= _UNIT_TOLERANCE:
        return nan
    unit = unit_vector(vector)
    return unit if unit is not None else nan


_DATUM = re.compile(r"^DAT\((.+)\)$", re.IGNORECASE)


def _datums(tol: Statement | None) -> str:
    """The datum reference frame a tolerance names (``DAT(A),DAT(B)`` → ``"A|B"``); "" when none."""
    if tol is None:
        return ""
    labels = [m.group(1).strip() for w in tol.words if (m := _DATUM.match(w.strip()))]
    return "|".join(labels)


#: DMIS feature words → the ``feature`` column (:mod:`parsers.geometry`).
_FEATURE_WORDS = {
    "POINT": "point",
    "EDGEPT": "edgepoint",
    "PLANE": "plane",
    "LINE": "line",
    "CIRCLE": "circle",
    "ARC": "arc",
    "CYLNDR": "cylinder",
    "CYLINDER": "cylinder",
    "CONE": "cone",
    "SPHERE": "sphere",
    "CPARLN": "slot",
    "PARPLN": "slot",
    "TORUS": "torus",
}
#: ``CORTOL`` words and tolerance types that give a size → the ``size`` column.
_SIZE_WORDS = {
    "DIAMETER": "diameter",
    "DIAM": "diameter",
    "RADIUS": "radius",
    "RAD": "radius",
    "WIDTH": "width",
    "LENGTH": "length",
}


def _geometry_cells(kind: str, values: list[str], feature: _Feature | None, name: str) -> dict[str, object]:
    """The geometry columns of a result: a ``CORTOL`` axis word's unit vector or a point profile's nominal
    normal (also when oblique) as the direction; the feature's type and ``INNER``/``OUTER`` side; the size a
    ``CORTOL,DIAMETER|RADIUS|WIDTH`` or ``DIAM``/``RAD`` result measures."""
    word = values[0].upper() if kind == "CORTOL" and values else ""
    direction: tuple[float, float, float] | None = None
    if word:
        direction = axis_vector(axis_word(word))
    elif kind == "PROFP" and feature is not None and feature.kind in _NORMAL_FEATURES and len(feature.values) >= 6:
        loc = SourceLocation(name, line=feature.line)
        direction = unit_vector([point_number(v, loc) for v in feature.values[3:6]])
    feature_word = _FEATURE_WORDS.get(feature.kind, "") if feature is not None else ""
    size = _SIZE_WORDS.get(word or kind, "")
    if size == "length" and feature_word != "slot":
        size = ""
    return geometry_cells(direction, feature_word, size, feature.side if feature is not None else "")


#: Features whose nominal ``FEAT/…,CART,x,y,z,i,j,k`` gives the surface normal (i, j, k) at x, y, z.
_NORMAL_FEATURES = {"POINT", "PLANE"}


def _axis(kind: str, values: list[str], feature: _Feature | None, name: str) -> str:
    """The machine axis of a result (:mod:`parsers.axes`): a ``CORTOL`` axis word (``XAXIS`` → X; DIAMETER,
    RADIAL, … → none), or for a point profile (``PROFP``) the nominal normal of its point or plane feature,
    when that is within 5° of an axis; ``""`` otherwise."""
    if kind == "CORTOL":
        return axis_word(values[0]) if values else ""
    if kind == "PROFP" and feature is not None and feature.kind in _NORMAL_FEATURES and len(feature.values) >= 6:
        loc = SourceLocation(name, line=feature.line)
        return vector_axis([point_number(v, loc) for v in feature.values[3:6]])
    return ""


def _is_number(text: str) -> bool:
    return is_number(text)
