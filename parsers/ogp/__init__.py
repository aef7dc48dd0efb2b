"""OGP SmartScope / Measure-X reader (step report, RTF-wrapped step report, run table); format ``ogp``."""

from __future__ import annotations

from parsers.ogp.reports import read_ogp, sniff_ogp
from parsers.ogp.rtf import is_rtf, rtf_lines
from parsers.registry import FormatSpec, register
from parsers.source import Peek, final_line_break

__all__ = ["read_ogp", "sniff_ogp"]


def _sniff(peek: Peek) -> bool:
    text = "\n".join(rtf_lines(peek.text)) if is_rtf(peek.text) else peek.text
    return sniff_ogp(text)


def _ogp_complete(data: bytes) -> str | None:
    """An RTF-wrapped report ends with its closing brace; a plain one with a line break."""
    if data.lstrip()[:5] == b"{\\rtf":
        return None if data.rstrip(b"\x00\r\n\t ")[-1:] == b"}" else "does not end with the RTF closing brace"
    return final_line_break(data)


register(
    FormatSpec(
        name="ogp",
        description="OGP SmartScope / Measure-X step report (also RTF-wrapped) or run table",
        extensions=(".rtf",),
        sniff=_sniff,
        read=read_ogp,
        priority=50,
        complete=_ogp_complete,
    )
)
