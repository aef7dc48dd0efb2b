"""QIF 3.x / 2.x results reader (registered as ``qif``)."""

from __future__ import annotations

from parsers.qif.reader import read_qif, sniff_qif
from parsers.registry import FormatSpec, register

__all__ = ["read_qif", "sniff_qif", "SPEC"]

SPEC = register(
    FormatSpec(
        name="qif",
        description="QIF 3.x / 2.x measurement results (XML; several parts per file)",
        extensions=(".qif",),
        sniff=lambda peek: sniff_qif(peek.text),
        read=read_qif,
        options=("unit",),
        priority=50,
    )
)
