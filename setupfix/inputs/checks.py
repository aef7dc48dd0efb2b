"""A report checked against the process model before anything is corrected.

The model holds the drawing's nominal and tolerances; a report states its own.  They
must agree, or the correction is computed for another part than the one measured:

* **unit** — a report nominal that is the model's times or divided by 25.4 is a
  report in inch read as mm (or the reverse): refused, since every deviation would
  be off by the same factor;
* **nominal / tolerance** — any other difference beyond rounding (a drawing
  revision, a nominal shifted by a program change, a report toleranced ±0.02 where
  the model says ±0.1) is a note naming the dimension and both values; the budget
  and "inside tolerance" use the model's limits.  ``strict=True`` refuses instead;
* **coverage** — a report that measures part of a fixture (one station of four) while
  a correction of a register shared with the unmeasured stations (a tool) moves those
  too: the error budget after holds for the measured dimensions only, said in a note.

"Beyond rounding" is max(resolution / 2, 2 % of the dimension's tolerance band): a
nominal printed in inch to four decimals (±0.00127 mm) passes on a ±0.1 mm band.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from setupfix.core.errors import MatchError, Note, SourceLocation
from setupfix.core.units import MM_PER_INCH
from setupfix.correction.relation import relation_matrices
from setupfix.model import PartMeasurement, ProcessModel

__all__ = ["check_parts", "difference_threshold", "UNIT_RATIO_TOLERANCE"]

#: Relative tolerance of the 25.4 ratio between a report's and the model's nominal.
UNIT_RATIO_TOLERANCE = 1e-3


def _fmt(value: float) -> str:
    return f"{value:.6g}"


def difference_threshold(model: ProcessModel, lower: float, upper: float) -> float:
    """The smallest difference between a report's and the model's value that is not rounding [model unit]."""
    band = upper - lower
    return max(model.resolution / 2, 0.02 * band if math.isfinite(band) else 0.0)


def _unit_error(model: ProcessModel, nominal: float, reported: float, threshold: float) -> str | None:
    """The unit confusion a 25.4 ratio reveals, or None."""
    if nominal == 0 or reported == 0 or abs(reported - nominal) <= threshold:
        return None
    tol = max(UNIT_RATIO_TOLERANCE * abs(nominal), threshold)
    if abs(reported * MM_PER_INCH - nominal) <= tol:
        return "the report's values are 25.4 times too small: inch values read as mm"
    if abs(reported / MM_PER_INCH - nominal) <= tol:
        return "the report's values are 25.4 times too large: mm values read as inch"
    return None


def check_parts(
    model: ProcessModel, parts: list[PartMeasurement], *, strict: bool = False, source: str = "<report>"
) -> list[PartMeasurement]:
    """Check each part's nominals, tolerances and coverage against the model.

    Parameters
    ----------
    model : ProcessModel
    parts : list of PartMeasurement
        As :func:`setupfix.model.match_parts` returns them (with the report's
        nominal and limits in the model unit).
    strict : bool
        Refuse a nominal or tolerance difference instead of noting it.
    source : str
        Report name for messages.

    Returns
    -------
    list of PartMeasurement
        The same parts with the check's notes appended.

    Raises
    ------
    MatchError
        On a unit confusion (factor 25.4), or on any difference when ``strict``.
    """
    composite = relation_matrices(model).composite  # (n_registers, n_dimensions)
    correctable = np.array([not r.fixed for r in model.registers], dtype=bool)
    expected = np.array([[d.nominal, d.lower, d.upper] for d in model.dimensions], dtype=float).T  # (3, n)
    thr = np.array([difference_threshold(model, d.lower, d.upper) for d in model.dimensions])
    out = []
    for part in parts:
        notes = list(part.notes)
        notes += _compare(model, part, expected, thr, strict=strict, source=source)
        notes += _coverage(model, part, composite, correctable, source)
        out.append(replace(part, notes=tuple(notes)))
    return out


def _compare(
    model: ProcessModel, part: PartMeasurement, expected: np.ndarray, thr: np.ndarray, *, strict: bool, source: str
) -> list[Note]:
    """Notes (and refusals) for one part; ``expected`` (3, n) model nominal/lower/upper, ``thr`` (n,)."""
    found: dict[str, list[tuple[str, SourceLocation]]] = {}  # difference text → dimensions showing it
    units: list[tuple[str, str, SourceLocation]] = []
    unit = model.unit
    dims = model.dimensions
    nan = np.full(len(dims), np.nan)
    given = np.vstack([v if v is not None else nan for v in (part.nominal, part.lower, part.upper)])
    with np.errstate(invalid="ignore"):
        off = np.abs(given - expected) > thr  # NaN (not given) compares False
    # Only dimensions with some difference are looked at one by one.
    for i in np.flatnonzero(part.measured & off.any(axis=0)):
        dim = dims[i]
        where = SourceLocation(part.sources[i] or source)
        reported, lo, up = (float(v) for v in given[:, i])
        if off[0, i]:
            why = _unit_error(model, dim.nominal, reported, float(thr[i]))
            if why:
                units.append(
                    (
                        dim.name,
                        f"report nominal {_fmt(reported)} {unit} against the model's {_fmt(dim.nominal)} {unit}: {why}",
                        where,
                    )
                )
                continue
            text = (
                f"the report's nominal {_fmt(reported)} {unit} differs from the model's "
                f"{_fmt(dim.nominal)} {unit} (a drawing or program revision? the model's is used)"
            )
            found.setdefault(text, []).append((dim.name, where))
        if off[1, i] or off[2, i]:
            shown = (
                f"{_fmt(lo) if math.isfinite(lo) else 'none'}/{'+' if up > 0 else ''}"
                f"{_fmt(up) if math.isfinite(up) else 'none'}"
            )
            text = (
                f"the report's tolerance {shown} {unit} differs from the model's "
                f"{_fmt(dim.lower)}/+{_fmt(dim.upper)} {unit}; the error budget and 'inside tolerance' "
                "use the model's"
            )
            found.setdefault(text, []).append((dim.name, where))
    if units:
        name, message, where = units[0]
        more = f" ({len(units) - 1} more dimension(s) alike)" if len(units) > 1 else ""
        raise MatchError(
            f"unit error at {name}: {message}{more}",
            location=where,
            hint="give --unit inch or --unit mm, or correct the report's unit",
        )
    notes = []
    for text, showing in found.items():
        names = [n for n, _ in showing]
        label = (
            names[0]
            if len(names) == 1
            else (f"{len(names)} dimensions ({', '.join(names[:4])}{', …' if len(names) > 4 else ''})")
        )
        notes.append(Note(f"{label}: {text}", showing[0][1], "mismatch"))
    if strict and notes:
        first = notes[0]
        more = f" ({len(notes) - 1} more difference(s))" if len(notes) > 1 else ""
        raise MatchError(
            f"{first.message}{more}; refused by --strict",
            location=first.location,
            hint="update the model to the drawing, or drop --strict to correct with the model's values",
        )
    return notes


def _coverage(
    model: ProcessModel, part: PartMeasurement, composite: np.ndarray, correctable: np.ndarray, source: str
) -> list[Note]:
    measured = part.measured
    if measured.all() or not composite.size:
        return []
    moves = composite != 0  # (registers, dimensions)
    shared = correctable & moves[:, measured].any(axis=1) & moves[:, ~measured].any(axis=1)
    if not shared.any():
        return []
    touched = moves[shared][:, ~measured].any(axis=0)
    absent_dims = [d for d, m in zip(model.dimensions, measured, strict=True) if not m]
    hit = [d for d, t in zip(absent_dims, touched, strict=True) if t]
    groups = sorted({d.group for d in hit if d.group})
    regs = [r.id for r, s in zip(model.registers, shared, strict=True) if s]
    where = (
        f"stations {', '.join(groups)}"
        if groups
        else ", ".join(d.name for d in hit[:5]) + (" …" if len(hit) > 5 else "")
    )
    return [
        Note(
            f"a correction of {', '.join(regs)} also moves {len(hit)} dimension(s) this report does not "
            f"measure ({where}): the error budget after holds for the measured dimensions only; "
            "measure the whole fixture, or hold those registers (fixed = true) for this report",
            SourceLocation(source),
            "coverage",
        )
    ]
