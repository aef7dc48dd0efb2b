"""PC-DMIS readers: text report (``pcdmis``) and CSV export (``pcdmis-csv``)."""

from __future__ import annotations

from parsers.pcdmis.csv_export import read_pcdmis_csv, sniff_pcdmis_csv
from parsers.pcdmis.text_report import read_pcdmis_text, sniff_pcdmis_text
from parsers.registry import FormatSpec, register
from parsers.source import final_line_break

__all__ = ["read_pcdmis_csv", "read_pcdmis_text"]

register(
    FormatSpec(
        name="pcdmis",
        description="Hexagon PC-DMIS text report (DIM blocks, AX NOMINAL +TOL -TOL MEAS DEV OUTTOL)",
        extensions=(),
        sniff=lambda peek: sniff_pcdmis_text(peek.text),
        read=read_pcdmis_text,
        priority=50,
        complete=final_line_break,
    )
)
register(
    FormatSpec(
        name="pcdmis-csv",
        description="PC-DMIS / Hexagon NC Gage CSV export (FEATURE, AXIS, NOMINAL, MEAS, +TOL, -TOL, DEV, OUTTOL)",
        extensions=(".csv",),
        sniff=lambda peek: sniff_pcdmis_csv(peek.text),
        read=read_pcdmis_csv,
        priority=40,
        complete=final_line_break,
    )
)
