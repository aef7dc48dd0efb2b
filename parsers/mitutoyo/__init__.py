"""Mitutoyo Quick Vision (QVPAK) text report reader; format ``qvpak``."""

from __future__ import annotations

from parsers.mitutoyo.qvpak import read_qvpak, sniff_qvpak
from parsers.registry import FormatSpec, register
from parsers.source import final_line_break

__all__ = ["read_qvpak", "sniff_qvpak"]

register(
    FormatSpec(
        name="qvpak",
        description="Mitutoyo Quick Vision (QVPAK) text report (Elemento Atual Nominal Desvio …)",
        extensions=(),
        sniff=lambda peek: sniff_qvpak(peek.text),
        read=read_qvpak,
        priority=50,
        complete=final_line_break,
    )
)
