"""The match table: what a report names and which dimension (or close names) it matches."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text

from setupfix.tui.widgets.plain import PlainTable
from setupfix.views.correction import IN, OUT, MatchRow

__all__ = ["MatchTable"]


class MatchTable(PlainTable):
    """One row per report characteristic: ✓ with its dimension, or ✗ with suggestions."""

    def on_mount(self) -> None:
        self.cursor_type = "row"

    def show(self, rows: Sequence[MatchRow]) -> None:
        self.clear(columns=True)
        for label in ("", "characteristic", "part", "station", "dimension", "did you mean"):
            self.add_column(label)
        for r in rows:
            self.add_row(
                Text(IN if r.matched else OUT, style="green" if r.matched else "red"),
                r.characteristic,
                r.part,
                r.station,
                r.dimension or "—",
                ", ".join(r.suggestions),
            )
