"""The history panel: the error budget over the last cycles and what the diagnosis found."""

from __future__ import annotations

from rich.text import Text
from textual.app import ComposeResult
from textual.containers import Vertical
from textual.widgets import DataTable, Sparkline, Static

__all__ = ["HistoryPanel"]


class HistoryPanel(Vertical):
    """Budget per cycle (sparkline and table) and the effects found, before/after."""

    def compose(self) -> ComposeResult:
        yield Static("", id="history-status")
        yield Sparkline([], id="history-curve")
        yield DataTable(id="history-effects", cursor_type="row")

    def not_available(self, reason: str) -> None:
        self.query_one("#history-status", Static).update(Text(f"not available: {reason}", style="dim"))
        self.query_one("#history-curve", Sparkline).display = False
        self.query_one("#history-effects", DataTable).display = False

    def status(self, text: str | Text) -> None:
        self.query_one("#history-status", Static).update(text)
