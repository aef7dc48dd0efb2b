"""The controller's current offsets (``--current FILE``, ``cli-json.md`` "Current offsets"): the one reader.

A CSV with the header ``register,value`` (any case; more columns after these two are
ignored).  ``register`` is the controller register (``G54``, ``H5``) or the model ID
(``W1``); ``value`` the register's current value in the model unit, written with a
decimal point.  Every correctable register of the model must be listed, so that a
*set* file is complete; a register the model does not know is an error (a typo would
otherwise pass unnoticed).

Refused, naming the file and line: a row with more cells than the header (a decimal
comma, ``G54,-412,5300``, would otherwise be read as −412 and its ``5300`` dropped), a
value that is not a plain decimal number or that no control holds (not finite, or
:data:`MAX_OFFSET_MM` or more in magnitude), an unknown or repeated register.
"""

from __future__ import annotations

from pathlib import Path

from parsers._source import csv_records, read_text
from parsers.numbers import try_number
from setupfix.errors import ParseError, SourceLocation
from setupfix.model import ProcessModel
from setupfix.units import length_factor

__all__ = ["read_current", "MAX_OFFSET_MM"]

#: No machine-tool control holds an offset this large [mm] (100 m): such a value is a misread.
MAX_OFFSET_MM = 1e5


def read_current(path: str | Path, model: ProcessModel) -> dict[str, float]:
    """Current values by register ID, model unit.

    Raises
    ------
    ParseError
        Naming the file and line: missing header, a row longer than the header, an
        unknown or repeated register, a value that is not a plain decimal number or
        that no control holds, a correctable register missing.
    """
    name = str(path)
    records = csv_records(read_text(path), name)
    head = next(records, None)
    if head is None or [c.strip().casefold() for c in head[1][:2]] != ["register", "value"]:
        raise ParseError("expected the header 'register,value'", location=SourceLocation(name, line=1))
    width = len(head[1])
    limit = MAX_OFFSET_MM * length_factor("mm", model.unit)
    out: dict[str, float] = {}
    for line, cells in records:
        if not any(c.strip() for c in cells):
            continue
        where = SourceLocation(name, line=line)
        if len(cells) < 2:
            raise ParseError("expected register,value", location=where)
        if len(cells) > width:
            raise ParseError(f"{len(cells)} cells but {width} columns in the header", location=where,
                             hint="a decimal comma splits a number in two: write -412.53, not -412,53")
        key, text = cells[0].strip(), cells[1].strip()
        try:
            reg = model.register(key)
        except KeyError:
            raise ParseError(f"register {key!r} is not in the model", location=where) from None
        if reg.id in out:
            raise ParseError(f"register {key!r} given twice", location=where)
        value = try_number(text)  # the project's one strict number parser (decimal point, finite)
        if value is None:
            raise ParseError(f"expected a decimal number, found {text[:30]!r}", location=where)
        if abs(value) >= limit:
            raise ParseError(f"value {text[:30]} of {key} is beyond any control's offset range "
                             f"(|value| < {limit:g} {model.unit})", location=where)
        out[reg.id] = value
    missing = [r.register for r in model.registers if not r.fixed and r.id not in out]
    if missing:
        raise ParseError(f"no current value for {', '.join(missing)}", location=SourceLocation(name))
    return out
