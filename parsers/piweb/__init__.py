"""ZEISS PiWeb REST JSON reader (values + characteristics); format ``piweb``."""

from __future__ import annotations

from parsers.piweb.rest_json import read_piweb, sniff_piweb
from parsers.registry import FormatSpec, register

__all__ = ["read_piweb", "sniff_piweb"]

register(
    FormatSpec(
        name="piweb",
        description="ZEISS PiWeb REST JSON values file (nominals from the characteristics file beside it)",
        extensions=(".json",),
        sniff=lambda peek: sniff_piweb(peek.text),
        read=read_piweb,
        priority=50,
    )
)
