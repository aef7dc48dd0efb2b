"""The match tab: what a report names and which dimension (or close names) it matches."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.widgets import DataTable, Static

from setupfix.tui.session import OpenedReport
from setupfix.tui.widgets.plain import plain
from setupfix.views.correction import IN, OUT, MatchRow

__all__ = ["MatchTable", "MatchPanel"]


class MatchTable(DataTable[Text]):
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
                *map(plain, (r.characteristic, r.part, r.station, r.dimension or "—", ", ".join(r.suggestions))),
            )


class MatchPanel(Vertical):
    """Whether the report matches the model, over the match table."""

    def compose(self) -> ComposeResult:
        yield Static("The report matches the model.", id="match-status")
        yield MatchTable(id="match-table")

    def show(self, opened: OpenedReport) -> None:
        """The report ``opened``: every characteristic matched, some left out, or none (``opened.problem``)."""
        self.query_one(MatchTable).show(opened.matches)
        status = self.query_one("#match-status", Static)
        if not opened.corrections:
            status.update(
                plain(
                    f"✗ {opened.problem}\nEach characteristic of the report, ✓ with the dimension it "
                    "matches, ✗ with the closest dimension names:"
                )
            )
        elif opened.unmatched:
            status.update(
                f"⚠ {opened.unmatched} characteristic(s) of the report match no dimension "
                "(✗ below, with the closest dimension names); they are left out."
            )
        else:
            status.update("✓ every characteristic of the report matches a dimension of the model.")
