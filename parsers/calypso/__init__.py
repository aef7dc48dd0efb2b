"""Zeiss CALYPSO ``*_chr.txt`` table reader (registered as ``calypso``)."""

from __future__ import annotations

from parsers.calypso.reader import read_calypso, sniff_calypso
from parsers.registry import FormatSpec, register
from parsers.source import end_statement

__all__ = ["read_calypso", "sniff_calypso", "SPEC"]

SPEC = register(
    FormatSpec(
        name="calypso",
        description="Zeiss CALYPSO characteristics table *_chr.txt (TAB separated, END line)",
        extensions=(),
        sniff=lambda peek: sniff_calypso(peek.text),
        read=read_calypso,
        priority=40,
        complete=end_statement("END"),
    )
)
