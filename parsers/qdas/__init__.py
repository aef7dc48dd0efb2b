"""Q-DAS AQDEF reader (``.dfq``, ``.dfd`` + ``.dfx``); registers format ``qdas``."""

from __future__ import annotations

from parsers.qdas.aqdef import read_aqdef, sniff_aqdef
from parsers.registry import FormatSpec, register
from parsers.source import final_line_break

__all__ = ["read_aqdef", "sniff_aqdef"]

register(
    FormatSpec(
        name="qdas",
        description="Q-DAS AQDEF transfer file (.dfq, or .dfd + .dfx/.dfb pair)",
        extensions=(".dfq", ".dfd", ".dfx", ".dfb"),
        sniff=lambda peek: sniff_aqdef(peek.text, peek.suffix),
        read=read_aqdef,
        priority=50,
        complete=final_line_break,
    )
)
