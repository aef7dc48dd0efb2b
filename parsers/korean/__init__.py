"""Korean production CMM text report reader (CP949); format ``korean``."""

from __future__ import annotations

from parsers.korean.report import read_korean, sniff_korean
from parsers.registry import FormatSpec, register
from parsers.source import Peek, decode, final_line_break

__all__ = ["read_korean", "sniff_korean"]


def _sniff(peek: Peek) -> bool:
    # The peek is decoded as UTF-8 or CP1252; this layout is CP949, so decode again.
    try:
        return sniff_korean(decode(peek.head, str(peek.path)))
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


register(
    FormatSpec(
        name="korean",
        description="Korean production CMM text report (품명/측정값/기준값 layout, CP949)",
        extensions=(),
        sniff=_sniff,
        read=read_korean,
        options=("unit", "encoding", "lenient"),
        priority=50,
        complete=final_line_break,
    )
)
