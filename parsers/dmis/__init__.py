"""DMIS output (``.dmo``) reader (registered as ``dmis``)."""

from __future__ import annotations

from parsers.dmis.reader import read_dmis, sniff_dmis
from parsers.registry import FormatSpec, register
from parsers.source import end_statement

__all__ = ["read_dmis", "sniff_dmis", "SPEC"]

SPEC = register(
    FormatSpec(
        name="dmis",
        description="DMIS output .dmo (F/T nominals, FA/TA results; one part per file)",
        extensions=(".dmo", ".dmi", ".dms"),
        sniff=lambda peek: sniff_dmis(peek.text),
        read=read_dmis,
        priority=50,
        complete=end_statement("ENDFIL"),
    )
)
