"""The controller's current offsets (``--current FILE``, ``cli-json.md`` "Current offsets"): the one reader.

One-axis model: a CSV with the header ``register,value`` (any case) and no other column:
the values go into the control, so a comment column, which would hide the second half of a
decimal comma (``G54,-412,530`` read as −412), is refused.  ``register`` is the controller
register (``G54``, ``H5``) or the model ID (``W1``); ``value`` the register's current value
in the model unit, written with a decimal point.

Multi-axis model (``process.axes``): the header ``register,axis,value``, one row per
register component.  A work offset's row names its axis — ``X``, ``Y``, ``Z`` or ``C``
(its rotation about the spindle, degrees) — after the register (``G54``) or the WKS ID
(``W1``); a tool's length register (``H5``) and radius register (``D5``) have the axis
empty, each named by its own register name or component ID (``T5``, ``T5.R``).  Values
are returned by component ID (``W1.X``, ``W1.C``, ``T5``, ``T5.R``).

Either way every correctable register (component) of the model must be listed, so that a
*set* file is complete; a register the model does not know is an error (a typo would
otherwise pass unnoticed).  Refused, naming the file and line: a header with any other
column (a comment, an empty one after a trailing comma, another delimiter), a row with more
cells than the header (a decimal comma, ``G54,-412,5300``, would otherwise be read as −412
and its ``5300`` dropped), a value that is not a plain decimal number or that no control holds (not
finite, or :data:`MAX_OFFSET_MM` or more in magnitude; a rotation :data:`MAX_OFFSET_MM`
degrees), an unknown or repeated register (component), a work offset without its axis or a
tool register with one.
"""

from __future__ import annotations

from pathlib import Path

from parsers.numbers import try_number
from parsers.source import csv_records, read_text
from setupfix.core.errors import ParseError, SourceLocation
from setupfix.core.units import length_factor
from setupfix.model import ProcessModel, Register

__all__ = ["read_current", "MAX_OFFSET_MM"]

#: No machine-tool control holds an offset this large [mm] (100 m): such a value is a misread.
MAX_OFFSET_MM = 1e5


def _base(reg: Register) -> str:
    """``W1`` of ``W1.X``; a register without a component suffix is its own base."""
    head, dot, tail = reg.id.rpartition(".")
    return head if dot and tail == reg.component else reg.id


def _component(model: ProcessModel, key: str, axis: str, where: SourceLocation) -> Register:
    """The register component a multi-axis row names (register or ID, and axis)."""
    folded = key.strip().casefold()
    wks = [r for r in model.wks if folded in (r.register.strip().casefold(), _base(r).casefold(), r.id.casefold())]
    tools = [r for r in model.tools if folded in (r.register.strip().casefold(), r.id.casefold())]
    if wks:
        if not axis:
            raise ParseError(f"register {key!r} is a work offset: give its axis (X, Y, Z or C)", location=where)
        exact = [r for r in wks if r.id.casefold() == folded]
        found = exact or [r for r in wks if (r.component or "").upper() == axis.upper()]
        if not found or (exact and (exact[0].component or "").upper() != axis.upper()):
            have = ", ".join(r.component or "?" for r in wks)
            raise ParseError(f"register {key!r} has no axis {axis!r} in the model (its axes: {have})", location=where)
        return found[0]
    if tools:
        if axis:
            raise ParseError(
                f"register {key!r} is a tool register: leave its axis empty (found {axis!r})", location=where
            )
        return tools[0]
    raise ParseError(f"register {key!r} is not in the model", location=where)


_DECIMAL_COMMA = "a decimal comma splits a number in two: write -412.53, not -412,53"


def _header_hint(found: list[str], columns: list[str]) -> str | None:
    """Why a header that starts right is still refused (the spec's columns only), else None."""
    if found[: len(columns)] != columns:
        return "the delimiter is a comma" if found and any(";" in c or "\t" in c for c in found) else None
    return "no other columns: the values go into the control, and a comment column hides a decimal comma"


def _label(reg: Register) -> str:
    return f"{reg.register} {reg.component}" if reg.kind == "wks" and reg.component else reg.register


def read_current(path: str | Path, model: ProcessModel) -> dict[str, float]:
    """Current values by register ID (component ID in a multi-axis model), model unit (a rotation in degrees).

    Raises
    ------
    ParseError
        Naming the file and line: missing header, a row longer than the header, an
        unknown or repeated register (component), a work offset's row without its axis
        or a tool's with one, a value that is not a plain decimal number or that no
        control holds, a correctable register (component) missing.
    """
    name = str(path)
    multi = model.multi_axis
    columns = ["register", "axis", "value"] if multi else ["register", "value"]
    records = csv_records(read_text(path), name)
    head = next(records, None)
    found = [c.strip().casefold() for c in head[1]] if head is not None else []
    if found != columns:
        why = " (a multi-axis model: one row per register component)" if multi else ""
        line, seen = (head[0], repr(",".join(head[1])[:60])) if head is not None else (1, "an empty file")
        raise ParseError(
            f"expected the header '{','.join(columns)}'{why}, found {seen}",
            location=SourceLocation(name, line=line),
            hint=_header_hint(found, columns),
        )
    width = len(columns)
    limit = MAX_OFFSET_MM * length_factor("mm", model.unit)
    out: dict[str, float] = {}
    for line, cells in records:
        if not any(c.strip() for c in cells):
            continue
        where = SourceLocation(name, line=line)
        if len(cells) < len(columns):
            raise ParseError(f"expected {','.join(columns)}", location=where)
        if len(cells) > width:
            raise ParseError(
                f"{len(cells)} cells but {width} columns in the header ({','.join(columns)})",
                location=where,
                hint=_DECIMAL_COMMA,
            )
        key, text = cells[0].strip(), cells[len(columns) - 1].strip()
        if multi:
            reg = _component(model, key, cells[1].strip(), where)
            shown = f"{key} {reg.component}" if reg.kind == "wks" else key
        else:
            try:
                reg = model.register(key)
            except KeyError:
                raise ParseError(f"register {key!r} is not in the model", location=where) from None
            shown = key
        if reg.id in out:
            raise ParseError(f"register {shown!r} given twice", location=where)
        value = try_number(text)  # the project's one strict number parser (decimal point, finite)
        if value is None:
            raise ParseError(
                f"expected a decimal number, found {text[:30]!r}",
                location=where,
                hint=_DECIMAL_COMMA if "," in text else None,
            )
        rotation = reg.component == "C" and reg.kind == "wks"
        bound, unit = (MAX_OFFSET_MM, "degrees") if rotation else (limit, model.unit)
        if abs(value) >= bound:
            raise ParseError(
                f"value {text[:30]} of {shown} is beyond any control's offset range (|value| < {bound:g} {unit})",
                location=where,
            )
        out[reg.id] = value
    missing = [_label(r) for r in model.registers if not r.fixed and r.id not in out]
    if missing:
        raise ParseError(f"no current value for {', '.join(missing)}", location=SourceLocation(name))
    return out
