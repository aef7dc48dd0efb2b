"""Postprocessors: CMM reports in their many formats → the canonical measurement table.

``read(path)`` returns a :class:`pandas.DataFrame` with the columns of
:data:`setupfix.model.CANONICAL_COLUMNS` (lengths in mm, ``deviation`` = actual −
nominal, limits as signed deviations, ``source`` = provenance of each row).  Each
format registers a :class:`FormatSpec`; importing this package registers the
built-in readers.
"""

from __future__ import annotations

from parsers._registry import FormatSpec, find_format, formats, read, register
from parsers import canonical as _canonical

__all__ = ["FormatSpec", "find_format", "formats", "read", "register"]

register(FormatSpec(
    name="canonical",
    description="setupfix canonical measurement CSV (shared/spec/measurements.md)",
    extensions=(".csv",),
    sniff=lambda peek: _canonical.sniff_canonical(peek.text),
    read=lambda path, unit=None, encoding=None, **_: _canonical.read_canonical(path, unit=unit),
    priority=10,
))
# Built-in readers register themselves on import; add one line per format package here.
