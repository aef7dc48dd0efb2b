"""The controller's current offsets: a CSV ``register,value`` (header line required).

``register`` is the controller register (``G54``, ``H5``) or the model ID (``W1``);
``value`` the register's current value in the model unit, written with a decimal
point.  Every correctable register of the model must be listed, so that a *set*
file is complete; a register the model does not know is an error (a typo would
otherwise pass unnoticed).
"""

from __future__ import annotations

from pathlib import Path

from parsers._source import csv_records, read_text
from parsers.numbers import try_number
from setupfix.errors import ParseError, SourceLocation
from setupfix.model import ProcessModel

__all__ = ["read_current"]


def read_current(path: str | Path, model: ProcessModel) -> dict[str, float]:
    """Current values by register ID.

    Raises
    ------
    ParseError
        Naming the file and line: missing header, unknown or repeated register, a
        value that is not a plain decimal number, a correctable register missing.
    """
    name = str(path)
    records = csv_records(read_text(path), name)
    head = next(records, None)
    if head is None or [c.strip().casefold() for c in head[1][:2]] != ["register", "value"]:
        raise ParseError("expected the header 'register,value'", location=SourceLocation(name, line=1))
    out: dict[str, float] = {}
    for line, cells in records:
        if not any(c.strip() for c in cells):
            continue
        where = SourceLocation(name, line=line)
        if len(cells) < 2:
            raise ParseError("expected register,value", location=where)
        key, text = cells[0].strip(), cells[1].strip()
        try:
            reg = model.register(key)
        except KeyError:
            raise ParseError(f"register {key!r} is not in the model", location=where) from None
        if reg.id in out:
            raise ParseError(f"register {key!r} given twice", location=where)
        value = try_number(text)  # the project's one strict number parser (decimal point)
        if value is None:
            raise ParseError(f"expected a decimal number, found {text[:30]!r}", location=where)
        out[reg.id] = value
    missing = [r.register for r in model.registers if not r.fixed and r.id not in out]
    if missing:
        raise ParseError(f"no current value for {', '.join(missing)}", location=SourceLocation(name))
    return out
